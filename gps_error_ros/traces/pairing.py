"""
Pair measured fixes with the ground truth at the fixes' own stamps.

The truth is interpolated linearly in time to each fix's stamp, but never
across a gap in the truth stream: a fix that falls in an interval between
two truth samples longer than ``max_truth_gap`` seconds, or outside the
truth's time span, is not used (and counted). Latitude/longitude are
interpolated directly, which is exact to well below a millimetre over the
sub-second to few-second intervals involved.
"""

from dataclasses import dataclass
from typing import Optional

import numpy as np

from gps_error_ros.model.state import FloatArray, Numbers
from gps_error_ros.traces.trace_io import Trace


class PairingError(ValueError):
    """Fixes and truth that cannot be paired (order, overlap)."""


@dataclass(frozen=True)
class PairingStats:
    """What was used and what was left out, and why."""

    fixes_in: int
    paired: int
    outside_truth: int
    in_truth_gap: int
    used: Optional[np.ndarray] = None      # which input fixes were paired (bool)

    def describe(self) -> str:
        """Return a one-line account for people."""
        return (f'{self.paired} of {self.fixes_in} fixes paired with truth '
                f'({self.outside_truth} outside the truth\'s time span, '
                f'{self.in_truth_gap} in gaps of the truth stream)')


def default_truth_gap(truth_t: Numbers) -> float:
    """
    Return the default largest truth interval that may be bridged (s).

    Three times the median truth interval, and at least 1.5 s.
    """
    if truth_t.size < 2:
        return 1.5
    return max(1.5, 3.0 * float(np.median(np.diff(truth_t))))


def _check_order(t: FloatArray, what: str) -> None:
    d = np.diff(t)
    if np.any(d <= 0):
        i = int(np.flatnonzero(d <= 0)[0])
        kind = 'duplicate stamp' if d[i] == 0 else 'time going backwards'
        raise PairingError(f'{what}: {kind} at sample {i + 1} (t={float(t[i + 1])!r} '
                           f'after {float(t[i])!r}): expected strictly increasing stamps')


def pair(fix_t: Numbers, fix_lat: Numbers, fix_lon: Numbers, truth_t: Numbers, truth_lat: Numbers,
         truth_lon: Numbers, max_truth_gap: Optional[float] = None,
         name: str = 'input') -> tuple[Trace, PairingStats]:
    """
    Return (Trace, PairingStats): each usable fix with the truth at its stamp.

    Parameters
    ----------
    fix_t
        The fixes' stamps in seconds (any epoch shared with the truth),
        strictly increasing.
    fix_lat
        The measured latitudes (degrees, WGS84).
    fix_lon
        The measured longitudes.
    truth_t
        The truth's stamps, strictly increasing.
    truth_lat
        The true latitudes.
    truth_lon
        The true longitudes.
    max_truth_gap
        Largest truth interval bridged by interpolation (default
        :func:`default_truth_gap`).
    name
        The input's name, for messages and the returned trace.

    Returns
    -------
    tuple
        ``(Trace, PairingStats)``.

    Raises
    ------
    PairingError
        Unordered or duplicate stamps, or no fix within the truth's span.

    """
    fix_t = np.asarray(fix_t, dtype=float)
    truth_t = np.asarray(truth_t, dtype=float)
    if fix_t.size == 0:
        raise PairingError(f'{name}: no usable fixes')
    if truth_t.size < 2:
        raise PairingError(f'{name}: {truth_t.size} truth sample(s): need at '
                           f'least 2 to interpolate')
    _check_order(fix_t, f'{name}: fixes')
    _check_order(truth_t, f'{name}: truth')
    gap = default_truth_gap(truth_t) if max_truth_gap is None else max_truth_gap
    inside = (fix_t >= truth_t[0]) & (fix_t <= truth_t[-1])
    if not inside.any():
        raise PairingError(
            f'{name}: the fixes ({fix_t[0]:.3f}..{fix_t[-1]:.3f} s) do not '
            f'overlap the truth ({truth_t[0]:.3f}..{truth_t[-1]:.3f} s): '
            f'expected truth around the fixes\' stamps')
    hi = np.clip(np.searchsorted(truth_t, fix_t, side='left'), 1, truth_t.size - 1)
    span = truth_t[hi] - truth_t[hi - 1]
    exact = truth_t[hi] == fix_t
    ok_gap = (span <= gap) | exact | (truth_t[hi - 1] == fix_t)
    use = inside & ok_gap
    w = np.clip((fix_t - truth_t[hi - 1]) / span, 0.0, 1.0)
    lat = truth_lat[hi - 1] + w * (truth_lat[hi] - truth_lat[hi - 1])
    lon = truth_lon[hi - 1] + w * (truth_lon[hi] - truth_lon[hi - 1])
    stats = PairingStats(int(fix_t.size), int(use.sum()), int((~inside).sum()),
                         int((inside & ~ok_gap).sum()), use)
    if not use.any():
        raise PairingError(f'{name}: no fix could be paired: {stats.describe()}')
    trace = Trace(name, fix_t[use] - fix_t[use][0], np.asarray(fix_lat)[use],
                  np.asarray(fix_lon)[use], lat[use], lon[use])
    return trace, stats
