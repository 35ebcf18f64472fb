"""
The mean part of a model: per axis a constant and AR terms, and the motion.

The error ``e`` is split into a motion term and an AR process ``u``::

    e(t) = gain * (truth(t - lag_s) - truth(t)) + u(t)
    u(t) = const + offset[phase(t)] + sum_i phi_i u(t - i) + innovation

``motion_lag`` is the family ``gain = 1`` with ``lag_s`` estimated; the
motion test uses the family with ``lag_s`` fixed and ``gain >= 0``
estimated, which is linear in its one coefficient so that each likelihood
ratio has the chi-bar-squared law. Both are fitted by profile least squares
(the conditional Gaussian likelihood of the mean part). With the
``periodic`` effect, ``offset`` (one per phase of a cycle of ``period``
steps, averaging zero) is estimated with the rest; a sample's phase is its
step from the trace's first fix modulo the period.
"""

from collections.abc import Callable, Sequence
from dataclasses import dataclass
import math
from typing import Optional

import numpy as np
from scipy import optimize

from gps_error_ros.diagnose.common import MAX_LAG_S, MOTION_TEST_LAGS, Orders
from gps_error_ros.fit.holdout import motion_offsets, Part, travel_headings, TruthTrack
from gps_error_ros.model.ar_model import inverse_root_modulus
from gps_error_ros.model.state import FloatArray, IntArray, Numbers


def to_travel_frame(r: FloatArray, heading: Numbers) -> FloatArray:
    """Return north/east innovations ``r`` (n, 2) as (along, across) the travel."""
    c, s = np.cos(heading), np.sin(heading)
    return np.stack([r[:, 0] * c + r[:, 1] * s, -r[:, 0] * s + r[:, 1] * c], axis=1)


def from_travel_frame(r: FloatArray, heading: Numbers) -> FloatArray:
    """Return (along, across) innovations ``r`` (n, 2) as north/east."""
    c, s = np.cos(heading), np.sin(heading)
    return np.stack([r[:, 0] * c - r[:, 1] * s, r[:, 0] * s + r[:, 1] * c], axis=1)


def condition_count(*orders: Orders) -> int:
    """Return how many samples per segment are conditioned on, not scored (by all ``orders``)."""
    return max(max(max(o) for o in orders), int(math.ceil(MAX_LAG_S)))


@dataclass
class Design:
    """Lagged regressions of one part for given orders and motion term."""

    y: np.ndarray          # (n, 2) u at the scored samples
    lags: list[np.ndarray]  # per axis (n, p_a) lagged u
    seg: np.ndarray        # (n,) segment index of each scored sample
    heading: Optional[np.ndarray] = None   # (n,) direction of travel, rad (street_frame)
    steps: Optional[np.ndarray] = None     # (n,) step from the trace's first fix (periodic)

    def phase(self, period: int) -> IntArray:
        """Return each scored sample's phase in a cycle of ``period`` steps."""
        if self.steps is None:
            raise ValueError('a periodic term needs the design\'s steps')
        return self.steps % period


def design(part: Part, orders: Orders, truth: TruthTrack, lag_s: float = 0.0,
           gain: float = 1.0, m0: int | None = None) -> Design:
    """Build the regression of u = e - motion term on its own past."""
    m0 = condition_count(orders) if m0 is None else max(m0, max(orders))
    offs = motion_offsets(part, truth, lag_s, gain)
    lens = np.array([len(e) for e in part.err], dtype=np.int64)
    counts = np.maximum(lens - m0, 0)
    total = int(counts.sum())
    if not total:
        return Design(np.zeros((0, 2)), [np.zeros((0, p)) for p in orders],
                      np.zeros(0, dtype=int), np.zeros(0), np.zeros(0, dtype=np.int64))
    # the segments one after another; each scored sample's index in that, and its lags'
    u = np.concatenate([e - o for e, o in zip(part.err, offs)])
    first = np.cumsum(lens) - lens + m0           # each segment's first scored sample
    idx = np.arange(total) + np.repeat(first - (np.cumsum(counts) - counts), counts)
    seg = np.repeat(np.arange(len(lens)), counts)
    times = np.concatenate(part.t)[idx]
    lags = [u[idx[:, None] - np.arange(1, orders[a] + 1)[None, :], a] for a in range(2)]
    steps = np.round(times - truth.t[0]).astype(np.int64)
    return Design(u[idx], lags, seg, travel_headings(truth, times, lag_s), steps)


@dataclass
class MeanFit:
    """The fitted mean part: constants, AR coefficients, motion term, cycle."""

    const: np.ndarray      # (2,)
    phi: list[np.ndarray]  # per axis array
    lag_s: float = 0.0
    gain: float = 1.0
    period: int = 0                 # periodic: the cycle's length, steps (0: none)
    offsets: Optional[np.ndarray] = None      # periodic: (period, 2) innovation mean by phase

    def residuals(self, d: Design) -> FloatArray:
        """Return the innovations of design ``d``, (n, 2)."""
        r = d.y - self.const
        if self.period and self.offsets is not None:
            r -= self.offsets[d.phase(self.period)]
        for a in range(2):
            r[:, a] -= d.lags[a] @ self.phi[a]
        return r


#: The largest spectral radius of a fitted AR part (see :func:`stationary_phi`).
MAX_RADIUS = 0.999


def stationary_phi(phi: FloatArray) -> FloatArray:
    """
    Return ``phi``, or, when its AR part is not stationary, the nearest of its shape that is.

    Conditional least squares, unlike Yule-Walker, can give an AR part with
    a root on or inside the unit circle (seen on a strongly persistent
    300-sample trace: phi 1.027), which no simulator can run. Scaling
    ``phi_i`` by ``c**i`` scales every inverse root by ``c``: the spectral
    radius is brought to :data:`MAX_RADIUS`, the dynamics keep their shape.
    """
    radius = inverse_root_modulus(phi)
    if radius < MAX_RADIUS:
        return phi
    c = MAX_RADIUS / radius
    return phi * c ** np.arange(1, len(phi) + 1)


def least_squares(d: Design, lag_s: float = 0.0, gain: float = 1.0,
                  period: int = 0) -> tuple[MeanFit, FloatArray]:
    """
    Fit the design per axis by least squares; return (MeanFit, residuals).

    With ``period``, one constant per phase in place of the one constant:
    ``const`` is their average and ``offsets`` the rest. An AR part fitted
    outside stationarity is pulled inside (:func:`stationary_phi`) and the
    constants refitted given it.
    """
    const, phis = np.zeros(2), []
    offsets = np.zeros((period, 2))
    if period:
        ones = (d.phase(period)[:, None] == np.arange(period)).astype(float)
    else:
        ones = np.ones((len(d.y), 1))
    k = ones.shape[1]
    for a in range(2):
        beta = np.linalg.lstsq(np.column_stack([ones, d.lags[a]]), d.y[:, a], rcond=None)[0]
        fitted = beta[k:]
        phi = stationary_phi(fitted)
        if phi is not fitted:       # pulled inside: the constants refitted given it
            beta = np.r_[np.linalg.lstsq(ones, d.y[:, a] - d.lags[a] @ phi,
                                         rcond=None)[0], phi]
        const[a] = beta[:k].mean()
        if period:
            offsets[:, a] = beta[:k] - const[a]
        phis.append(beta[k:])
    mf = MeanFit(const, phis, lag_s, gain, period, offsets if period else None)
    return mf, mf.residuals(d)


def _profile_minimum(loss: Callable[[float], float], hi: float) -> tuple[float, float]:
    """Return (the minimiser of ``loss`` on [0, hi], the minimum): a grid, then refined."""
    grid = np.linspace(0.0, hi, 26)
    vals = [loss(g) for g in grid]
    i = int(np.argmin(vals))
    lo, up = grid[max(0, i - 1)], grid[min(len(grid) - 1, i + 1)]
    best, low = grid[i], vals[i]
    if up > lo:
        res = optimize.minimize_scalar(loss, bounds=(lo, up), method='bounded',
                                       options={'xatol': 1e-3})
        if res.fun < vals[i]:
            best, low = float(res.x), float(res.fun)
    return best, low


def log_det_loss(part: Part, orders: Orders, truth: TruthTrack, lag_s: float, gain: float,
                 period: int = 0, clean: Callable[[Design], Design] | None = None) -> float:
    """
    Return the sum over the axes of the log mean square least-squares residual.

    The mean part's profile loss: ``n/2`` times it is minus the Gaussian log
    likelihood with independent axes, up to a constant. ``clean``: a function
    of the design that the loss is taken on.
    """
    d = design(part, orders, truth, lag_s, gain)
    return log_det(least_squares(d if clean is None else clean(d), period=period)[1])


def log_det(r: FloatArray) -> float:
    """Return the sum over the axes of the log mean square of residuals ``r`` (n, 2)."""
    return float(np.sum(np.log(np.mean(r * r, axis=0))))


def fit_mean(part: Part, orders: Orders, truth: TruthTrack, lag_s: float = 0.0,
             gain: float = 1.0, period: int = 0) -> tuple[MeanFit, FloatArray, Design]:
    """Fit the mean part with a fixed motion term; return (MeanFit, r, Design)."""
    d = design(part, orders, truth, lag_s, gain)
    return least_squares(d, lag_s, gain, period) + (d,)


def fit_lag(part: Part, orders: Orders, truth: TruthTrack, period: int = 0,
            clean: Callable[[Design], Design] | None = None) -> float:
    """
    Return the lag (s, in [0, MAX_LAG_S], gain 1) of least log-det loss.

    ``clean``: a function of the design that the loss is taken on (the
    diagnosis passes one that sets jumps aside).
    """
    return _profile_minimum(
        lambda tau: log_det_loss(part, orders, truth, tau, 1.0, period, clean), MAX_LAG_S)[0]


def fit_mean_lag(part: Part, orders: Orders, truth: TruthTrack,
                 period: int = 0) -> tuple[MeanFit, FloatArray, Design]:
    """Fit the mean part with ``lag_s`` in [0, MAX_LAG_S] estimated (gain 1)."""
    return fit_mean(part, orders, truth, fit_lag(part, orders, truth, period), 1.0, period)


def gain_loss(part: Part, orders: Orders, truth: TruthTrack, lag_s: float,
              clean: Callable[[Design], Design] | None = None) -> tuple[float, float]:
    """Return (least log-det loss over the gain in [0, 5] at ``lag_s``, the gain)."""
    best, low = _profile_minimum(
        lambda g: log_det_loss(part, orders, truth, lag_s, g, clean=clean), MAX_LAG_S)
    return low, best


def fit_mean_gain(part: Part, orders: Orders, truth: TruthTrack,
                  lag_s: float) -> tuple[MeanFit, FloatArray, Design]:
    """Fit the mean part at a fixed ``lag_s`` with the gain in [0, 5] estimated."""
    return fit_mean(part, orders, truth, lag_s, gain_loss(part, orders, truth, lag_s)[1])


def motion_correlation(part: Part, orders: Orders, truth: TruthTrack, phi: Sequence[FloatArray],
                       weights: Numbers, clean: Callable[[Design], Design] | None = None
                       ) -> FloatArray:
    """
    Return the correlation of the motion probes' score statistics across the lags.

    The probe at lag L adds ``gain x (truth(t - L) - truth(t))``; through the
    AR filter ``phi`` its regressor in the innovations is that offset minus
    ``phi`` times its past, centred per axis (the constant is fitted too)
    and weighted per axis by ``weights`` (inverse innovation variances).
    Under no motion term the scores are asymptotically Gaussian with these
    correlations, whatever the lag. ``clean``: as for :func:`log_det_loss`.
    """
    def build(lag_s: float, gain: float) -> Design:
        d = design(part, orders, truth, lag_s, gain)
        return d if clean is None else clean(d)

    d0, cols = build(0.0, 0.0), []
    for lag in MOTION_TEST_LAGS:
        d = build(float(lag), 1.0)
        x = [(d0.y[:, a] - d.y[:, a]) - (d0.lags[a] - d.lags[a]) @ phi[a] for a in range(2)]
        cols.append(np.concatenate([(v - v.mean()) * math.sqrt(w) for v, w in zip(x, weights)]))
    gram = np.array(cols) @ np.array(cols).T
    scale = np.sqrt(np.maximum(np.diag(gram), 1e-300))
    return gram / np.outer(scale, scale)
