"""What a recording reader returns: fixes as arrays, and what it skipped."""

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np


@dataclass
class Recording:
    """
    The usable fixes of a recording (a phone's log, a receiver's NMEA).

    ``extra`` holds optional trace-CSV columns by name (``speed`` m/s,
    ``bearing`` deg, ``hdop``, ``accuracy`` m), each an array like ``t``.
    """

    t: np.ndarray               # UTC, s since 1970
    lat: np.ndarray
    lon: np.ndarray
    alt: np.ndarray             # ellipsoidal height, m (NaN where unknown)
    extra: dict[str, Any] = field(default_factory=dict)
    skipped: dict[str, int] = field(default_factory=dict)

    def describe(self) -> str:
        """Return a line for people: fixes kept and what was skipped."""
        sk = ', '.join(f'{v} {k}' for k, v in self.skipped.items() if v)
        return f'{self.t.size} fixes' + (f' ({sk} skipped)' if sk else '')


def time_ordered(rows: Sequence[Sequence[Any]], skipped: dict[str, int]) -> Any:
    """
    Return ``rows`` (t first) as an array sorted by time, one row per time.

    A second fix at a time already seen is dropped and counted in
    ``skipped['duplicate time']`` (the first in the file is kept).
    """
    a = np.array(rows, dtype=float).reshape(len(rows), -1)
    a = a[np.argsort(a[:, 0], kind='stable')]
    keep = np.r_[True, np.diff(a[:, 0]) > 0]
    if not keep.all():
        skipped['duplicate time'] = skipped.get('duplicate time', 0) + int((~keep).sum())
    return a[keep]
