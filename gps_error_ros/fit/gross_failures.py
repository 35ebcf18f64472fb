"""
Gross failures: fixes that are not a noisy estimate of the position at all.

A snapshot receiver whose solution failed, or a phone that jumped to a wrong
cell, reports a point tens of metres to kilometres away. Such a fix is
not an error of the process the profile models: a handful of them would set
the whole fit (``sigma_w`` in kilometres). This module finds them by one
stated rule, relative to the trace's own robust spread, so that it does not
depend on any one data set:

* per axis, the robust centre ``m`` (median) and robust scale ``s``
  (1.4826 x the median absolute deviation; where that is 0, as with a phone
  that repeats quantised positions, 1.2533 x the mean absolute deviation
  about the median; both are the SD for Gaussian data);
* the global distance ``d_g = |((n - m_n) / s_n, (e - m_e) / s_e)|`` of a
  fix's error from the centre, and the local distance ``d_l``, the same with
  the error's departure from the median of its ``2 x NEIGHBOURS`` neighbours
  (the fix itself left out);
* a fix is a gross failure when both exceed ``K`` (:data:`K_ROBUST_SD`) and
  it lies more than :data:`MIN_DEPARTURE_M` from the recording's median error:
  a fix a few metres off is an estimate of the position, however steady the
  receiver was otherwise (a phone that repeats one position for minutes has
  a robust spread near zero, and its 5 m moves are not failures).

The global test says the fix is far outside what the trace does; the local
one that it is not where its neighbours are, so a persistent phone's slow
excursion (twenty fixes at five robust SDs, each beside the last) is the
error process, not a failure. For Gaussian errors ``d_g^2`` is chi-squared
with 2 degrees of freedom, so a clean fix passes ``K = 5`` with probability
``exp(-12.5) = 3.7e-6``. Measured on clean Gaussian AR(1) traces of 200 to
1800 steps with phi 0 to 0.995 and an SD of 10 m (300 traces each, ``python -m
gps_error_ros.fit.gross_failures --false-positives``): at most 6e-6 flagged
per fix, where the global test alone flags up to 8e-4 on short, persistent
traces (phi 0.995, 200 steps).

The failures are listed (time, distance from the truth) by the commands that
read traces, and kept out of the error-process fit: the trace the fit sees
has them as missing steps. Their rate and sizes may be carried by a
profile's ``gross_failures`` section (:mod:`~gps_error_ros.model.failures`).
"""

from dataclasses import dataclass
from typing import Any, Optional, Sequence

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from gps_error_ros.model.failures import MAX_AGENT_RATE, MAX_RATE_SD_LOG, rate_nodes, rate_of
from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.state import BoolArray, FloatArray, Numbers
from gps_error_ros.traces.trace_io import recordings_of, Trace

#: The robust distance (in robust SDs) beyond which a fix is a gross failure.
K_ROBUST_SD = 5.0
#: The least distance (m) from the recording's median error of a gross failure.
MIN_DEPARTURE_M = 25.0
#: The least robust scale (m) of an axis: a constant one (0) is taken as 1 mm.
MIN_SCALE_M = 1e-3
#: Neighbours on each side that give a fix's local reference (median).
NEIGHBOURS = 5
#: Mean absolute deviation to SD (Gaussian), the scale when the MAD is 0.
_MEAN_ABS_TO_SD = 1.2533
_MAD_TO_SD = 1.4826


def robust_centre_scale(x: Numbers) -> tuple[Any, Any]:
    """
    Return (median, robust SD) of ``x`` (the module docstring's scale).

    The robust SD is 1.4826 x the MAD, or 1.2533 x the mean absolute
    deviation about the median when the MAD is 0 (0 for a constant).
    """
    x = np.asarray(x, dtype=float)
    m = float(np.median(x))
    dev = np.abs(x - m)
    s = _MAD_TO_SD * float(np.median(dev))
    if s == 0.0:
        s = _MEAN_ABS_TO_SD * float(np.mean(dev))
    return m, s


def _neighbour_median(x: FloatArray, h: int) -> FloatArray:
    """Return the median of each element's ``h`` neighbours on each side (itself out)."""
    pad = np.r_[np.full(h, np.nan), x, np.full(h, np.nan)]
    win = sliding_window_view(pad, 2 * h + 1).copy()
    win[:, h] = np.nan
    ok = np.isfinite(win).any(axis=1)
    out = np.full(x.size, np.nan)
    out[ok] = np.nanmedian(win[ok], axis=1)
    return out


def failure_mask(north: Numbers, east: Numbers, k: float = K_ROBUST_SD,
                 neighbours: int = NEIGHBOURS,
                 min_departure_m: float = MIN_DEPARTURE_M) -> BoolArray:
    """
    Return the gross failures of an error series (the module docstring's rule).

    Parameters
    ----------
    north
        The north errors (m), in time order; one recording (neighbours are
        taken along it).
    east
        The east errors (m), likewise.
    k
        The robust distance both tests must exceed.
    neighbours
        Fixes on each side giving the local reference.
    min_departure_m
        The least distance (m) from the median error of a gross failure.

    Returns
    -------
    numpy.ndarray
        Boolean, True at a gross failure. All False with fewer than 3 fixes.

    """
    err = np.stack([np.asarray(north, dtype=float), np.asarray(east, dtype=float)], axis=1)
    n = err.shape[0]
    if n < 3:
        return np.zeros(n, dtype=bool)
    dg = np.empty_like(err)
    dl = np.empty_like(err)
    away = np.empty_like(err)
    for a in range(2):
        m, s = robust_centre_scale(err[:, a])
        s = max(s, MIN_SCALE_M)             # a constant axis: MIN_DEPARTURE_M decides
        away[:, a] = err[:, a] - m
        dg[:, a] = away[:, a] / s
        dl[:, a] = (err[:, a] - _neighbour_median(err[:, a], neighbours)) / s
    return (np.hypot(dg[:, 0], dg[:, 1]) > k) & (np.hypot(dl[:, 0], dl[:, 1]) > k) & \
        (np.hypot(away[:, 0], away[:, 1]) > min_departure_m)


@dataclass(frozen=True)
class GrossFailures:
    """The gross failures found in a trace, and the rule that found them."""

    mask: np.ndarray        # per trace row
    t: np.ndarray           # their times, s
    size_m: np.ndarray      # their horizontal distance from the truth, m
    rows: int               # the trace's rows
    scale_m: tuple[float, ...]  # the robust SD per axis (north, east), m
    name: str = ''          # the recording's

    @property
    def count(self) -> int:
        """Return the number of gross failures."""
        return int(self.mask.sum())

    @property
    def rate(self) -> float:
        """Return the share of fixes that are gross failures."""
        return self.count / self.rows if self.rows else 0.0

    def describe(self, listed: int = 5, kept_out: bool = True) -> str:
        """
        Return a line for people: how many, which, and the rule.

        ``kept_out``: the command leaves them out of its error fit (else they
        stay in what it writes, and the line says calibrate leaves them out).
        """
        name = self.name
        rule = (f'more than {K_ROBUST_SD:g} robust SDs (north {self.scale_m[0]:.3g} m, '
                f'east {self.scale_m[1]:.3g} m) from both the trace\'s median error and '
                f'its neighbours\', and {MIN_DEPARTURE_M:g} m from the median')
        if not self.count:
            return f'{name}: no gross failures ({rule})'
        order = np.argsort(-self.size_m)[:listed]
        items = ', '.join(f't={self.t[i]:.0f} s {self.size_m[i]:.0f} m' for i in order)
        more = f' and {self.count - listed} more' if self.count > listed else ''
        fate = 'kept out of the error fit' if kept_out else \
            'kept in the trace, calibrate leaves them out'
        return (f'{name}: {self.count} gross failure(s) of {self.rows} fixes ({rule}), '
                f'{fate}; largest: {items}{more}')

    def to_dict(self) -> dict[str, Any]:
        """Return the findings as plain data (the fit and JSON reports carry it)."""
        return {'rule': f'robust distance > {K_ROBUST_SD:g} from the trace median and '
                        f'from the median of {NEIGHBOURS} neighbours each side, and more '
                        f'than {MIN_DEPARTURE_M:g} m from the trace median',
                'robust_sd_m': [round(float(v), 4) for v in self.scale_m],
                'count': self.count, 'fixes': self.rows,
                'rate': round(self.rate, 6),
                'failures': [{'t': round(float(t), 3), 'size_m': round(float(s), 2)}
                             for t, s in zip(self.t, self.size_m)]}


def find_gross_failures(trace: Trace) -> GrossFailures:
    """Return the :class:`GrossFailures` of a trace (see the module docstring)."""
    north, east = difference(trace.lat, trace.lon, trace.truth_lat, trace.truth_lon)
    mask = failure_mask(north, east)
    scale = tuple(robust_centre_scale(v)[1] for v in (north, east))
    return GrossFailures(mask, trace.t[mask], np.hypot(north, east)[mask], len(trace), scale,
                         trace.name)


def without_gross_failures(recordings: Trace | Sequence[Trace]
                           ) -> tuple[list[Trace], list[GrossFailures]]:
    """
    Return each recording without its gross failures, and the failures found.

    ``recordings``: a trace or a sequence of them; each recording's failures
    are found on its own (its own robust spread and median), as the commands
    do. Returns (list of traces, list of :class:`GrossFailures`).
    """
    traces = recordings_of(recordings)
    found = [find_gross_failures(t) for t in traces]
    return [without_rows(t, f.mask) for t, f in zip(traces, found)], found


def failures_doc(found: Sequence[GrossFailures]) -> dict[str, dict[str, Any]]:
    """Return the recordings' gross failures as plain data, keyed by recording."""
    return {f.name: f.to_dict() for f in found}


#: Recordings needed before the rate's spread between receivers is fitted.
MIN_RECORDINGS_FOR_SPREAD = 3
#: A fitted spread below this is written as none (one rate for every agent).
MIN_RATE_SD_LOG = 0.01


def fit_rate_spread(counts: Numbers, fixes: Numbers) -> tuple[float, Optional[float]]:
    """
    Return the mean rate and the SD of the log rate, fitted from each recording's failures.

    Each recording is one agent with rate ``r exp(s z - s^2 / 2)``, ``z``
    standard normal, and a binomial count of failures among its fixes (the
    law of :meth:`~gps_error_ros.model.failures.GrossFailureProcess.count_law`);
    ``(r, s)`` maximise the likelihood of the counts (``z`` on the grid of
    :func:`~gps_error_ros.model.failures.rate_nodes`, as the law has it).
    Returns ``(r, None)``, ``r`` the pooled ``sum(counts) / sum(fixes)``,
    with fewer than :data:`MIN_RECORDINGS_FOR_SPREAD`
    recordings, no failure, or a spread below :data:`MIN_RATE_SD_LOG`.
    """
    from scipy import optimize, stats
    counts = np.asarray(counts, dtype=float)
    fixes = np.asarray(fixes, dtype=float)
    pooled = float(counts.sum() / fixes.sum()) if fixes.sum() > 0 else 0.0
    if counts.size < MIN_RECORDINGS_FOR_SPREAD or counts.sum() == 0:
        return pooled, None
    z, logw = rate_nodes()

    def nll(p: FloatArray) -> float:
        rates = rate_of(np.exp(p[0]), p[1], z)
        ll = stats.binom.logpmf(counts[:, None], fixes[:, None], rates[None, :]) + logw
        top = ll.max(axis=1, keepdims=True)
        return -float(np.sum(top[:, 0] + np.log(np.exp(ll - top).sum(axis=1))))

    best = min((optimize.minimize(nll, [np.log(pooled), s0], method='L-BFGS-B',
                                  bounds=[(np.log(1e-9), np.log(MAX_AGENT_RATE)),
                                          (0.0, MAX_RATE_SD_LOG)])
                for s0 in (0.1, 1.0)), key=lambda res: res.fun)
    if best.x[1] < MIN_RATE_SD_LOG:
        return pooled, None
    return float(np.exp(best.x[0])), float(best.x[1])


def without_rows(trace: Trace, mask: BoolArray) -> Trace:
    """Return ``trace`` without the rows where ``mask`` is True (same name, extras kept)."""
    keep = ~np.asarray(mask, dtype=bool)
    if keep.all():
        return trace
    return type(trace)(name=trace.name, t=trace.t[keep], lat=trace.lat[keep],
                       lon=trace.lon[keep], truth_lat=trace.truth_lat[keep],
                       truth_lon=trace.truth_lon[keep],
                       extra={k: v[keep] for k, v in trace.extra.items()})


def false_positive_rate(phis: Sequence[float] = (0.0, 0.5, 0.9, 0.98, 0.995),
                        lengths: Sequence[int] = (200, 600, 1800), traces: int = 300,
                        seed: int = 20261125,
                        sd_m: float = 10.0) -> dict[tuple[float, int], float]:
    """
    Return {(phi, length): flagged share per fix} on clean Gaussian AR(1) traces.

    Both axes independent with stationary SD ``sd_m`` (10 m, a snapshot
    receiver's: five robust SDs are then beyond :data:`MIN_DEPARTURE_M`, so
    the robust tests decide), burn-in 2000 steps; the figure the module
    docstring quotes.
    """
    from scipy import signal
    rng = np.random.default_rng(seed)
    out: dict[tuple[float, int], float] = {}
    for phi in phis:
        for n in lengths:
            flagged = 0
            for _ in range(traces):
                z = rng.standard_normal((2, n + 2000))
                x = signal.lfilter([1.0], [1.0, -phi], z, axis=-1)[:, 2000:]
                x *= sd_m * np.sqrt(1.0 - phi ** 2)
                flagged += int(failure_mask(x[0], x[1]).sum())
            out[(phi, n)] = flagged / (traces * n)
    return out


if __name__ == '__main__':
    import sys
    if '--false-positives' not in sys.argv[1:]:
        sys.exit('usage: python -m gps_error_ros.fit.gross_failures --false-positives')
    for (phi, n), share in false_positive_rate().items():
        print(f'phi {phi:<6g} {n:5d} steps: {share:.1e} flagged per fix')
