"""What a recording reader returns: fixes as arrays, and what it skipped."""

from dataclasses import dataclass, field

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
    extra: dict = field(default_factory=dict)
    skipped: dict = field(default_factory=dict)

    def describe(self):
        """Return a line for people: fixes kept and what was skipped."""
        sk = ', '.join(f'{v} {k}' for k, v in self.skipped.items() if v)
        return f'{self.t.size} fixes' + (f' ({sk} skipped)' if sk else '')
