"""
Calibrate a profile from measured errors: the paper's procedure, with gaps.

1. Errors are taken at the fixes' own stamps (north/east metres from the
   truth at the same instant) and placed on the model's grid by nearest step.
   Errors are never interpolated. A missing step is a gap, and gaps split the
   data into segments.
2. The autocovariance is pooled over segments (products only within a
   segment, about the pooled mean, divided by the total sample count: the
   biased estimator, so the Toeplitz matrix stays positive semi-definite).
3. The order is the paper's choice unless fixed: the largest lag up to
   ``max_order`` whose partial autocorrelation lies outside the significance
   bound ``z / sqrt(n)`` (z = 1.96, 5 %). BIC's choice is recorded beside it.
4. Yule-Walker gives phi and sigma_w; ``delta = (1 - sum phi) * mean``
   (Eq. 3). A non-stationary fit, or too few samples for the order, is refused.
"""

from dataclasses import dataclass
import math

import numpy as np
from scipy import linalg
import yaml

from .ar_model import AXES, AxisParams, is_stationary, ModelError
from .geodesy import difference

PACF_Z = 1.959963984540054
DEFAULT_MAX_ORDER = 10


def _num(value, digits=6):
    """Return ``value`` as a plain float rounded for a YAML file."""
    return round(float(value), digits)


class CalibrationError(ValueError):
    """Data that cannot give a profile (too few samples, not stationary)."""


@dataclass(frozen=True)
class GriddedErrors:
    """Errors on the model grid, split at gaps into segments."""

    segments: tuple
    starts: tuple
    rate_hz: float
    rows: np.ndarray = None   # trace row of each sample, segments concatenated

    @property
    def n(self):
        """Return the total number of samples."""
        return int(sum(len(s) for s in self.segments))

    @property
    def span_s(self):
        """Return the time from the first to the last sample, in seconds."""
        last = self.starts[-1] + len(self.segments[-1]) - 1
        return (last - self.starts[0]) / self.rate_hz

    def axis(self, a):
        """Return the segments of axis ``a`` (0 north, 1 east)."""
        return [s[:, a] for s in self.segments]


def errors_on_grid(trace, rate_hz=1.0):
    """Return the trace's north/east errors as :class:`GriddedErrors`."""
    north, east = difference(trace.lat, trace.lon, trace.truth_lat,
                             trace.truth_lon)
    pos = (trace.t - trace.t[0]) * rate_hz
    step = np.rint(pos).astype(np.int64)
    off = np.abs(pos - step)
    # Two fixes on one step: keep the one nearest the step's instant.
    order = np.lexsort((off, step))
    keep = order[np.r_[True, np.diff(step[order]) != 0]]
    step, err = step[keep], np.stack([north, east], axis=1)[keep]
    cuts = np.flatnonzero(np.diff(step) > 1) + 1
    segs = np.split(err, cuts)
    starts = np.split(step, cuts)
    return GriddedErrors(tuple(segs), tuple(int(s[0]) for s in starts),
                         float(rate_hz), keep)


def pooled_autocovariance(segments, max_lag, mean=None):
    """Return the pooled biased autocovariance at lags 0..max_lag and n."""
    n = sum(len(s) for s in segments)
    if mean is None:
        mean = sum(float(np.sum(s)) for s in segments) / n
    acv = np.zeros(max_lag + 1)
    for s in segments:
        d = np.asarray(s, dtype=float) - mean
        for k in range(min(max_lag, len(d) - 1) + 1):
            acv[k] += d[:len(d) - k] @ d[k:]
    return acv / n, n, mean


def durbin_levinson(acv, max_lag):
    """
    Return (pacf at lags 1..max_lag, innovation variance for orders 0..max_lag).

    From an autocovariance sequence, by the Durbin-Levinson recursion.
    """
    pacf = np.zeros(max_lag)
    var = np.zeros(max_lag + 1)
    var[0] = acv[0]
    phi = np.zeros(0)
    for k in range(1, max_lag + 1):
        a = (acv[k] - phi @ acv[1:k][::-1]) / var[k - 1]
        phi = np.r_[phi - a * phi[::-1], a]
        pacf[k - 1] = a
        var[k] = var[k - 1] * (1 - a * a)
    return pacf, var


@dataclass(frozen=True)
class AxisFit:
    """Calibration of one axis, with the order-selection evidence."""

    params: AxisParams
    mean: float
    pacf: tuple
    pacf_bound: float
    pacf_order: int
    bic: tuple
    bic_order: int
    fixed_order: bool

    def evidence(self):
        """Return the order-selection evidence as plain data."""
        return {
            'order': self.params.order,
            'order_fixed_by_user': self.fixed_order,
            'pacf': [_num(v, 4) for v in self.pacf],
            'pacf_bound': _num(self.pacf_bound, 4),
            'pacf_order': self.pacf_order,
            'bic': [_num(v, 2) for v in self.bic],
            'bic_order': self.bic_order,
            'mean_m': _num(self.mean, 4),
        }


def fit_axis(segments, order=None, max_order=DEFAULT_MAX_ORDER, axis='axis'):
    """Fit one axis from its segments (see the module docstring)."""
    if order is not None and order < 1:
        raise CalibrationError(f'order must be >= 1, got {order}')
    if max_order < 1:
        raise CalibrationError(f'max_order must be >= 1, got {max_order}')
    lags = max(max_order, order or 0)
    n = sum(len(s) for s in segments)
    need = max(20, 4 * (lags + 1))
    if n < need:
        raise CalibrationError(
            f'{axis}: {n} samples are too few for order selection up to lag '
            f'{lags} (need at least {need})')
    acv, n, mean = pooled_autocovariance(segments, lags)
    if not acv[0] > 0:
        raise CalibrationError(f'{axis}: the errors are constant; no AR model '
                               f'can be fitted')
    pacf, var = durbin_levinson(acv, lags)
    bound = PACF_Z / math.sqrt(n)
    significant = np.flatnonzero(np.abs(pacf[:max_order]) > bound)
    pacf_order = int(significant[-1] + 1) if significant.size else 1
    bic = n * np.log(var[1:max_order + 1]) + np.arange(1, max_order + 1) * np.log(n)
    bic_order = int(np.argmin(bic) + 1)
    p = order or pacf_order
    phi = linalg.solve_toeplitz(acv[:p], acv[1:p + 1])
    sigma2 = acv[0] - phi @ acv[1:p + 1]
    if not is_stationary(phi) or not sigma2 > 0:
        raise CalibrationError(
            f'{axis}: the Yule-Walker AR({p}) fit phi={np.round(phi, 4).tolist()} '
            f'is not stationary')
    try:
        params = AxisParams((1 - phi.sum()) * mean, tuple(phi),
                            float(np.sqrt(sigma2)))
    except ModelError as exc:
        raise CalibrationError(f'{axis}: {exc}') from None
    return AxisFit(params, float(mean), tuple(pacf[:max_order]), bound,
                   pacf_order, tuple(bic), bic_order, order is not None)


@dataclass(frozen=True)
class CalibrationResult:
    """A fitted profile and how it was obtained."""

    north: AxisFit
    east: AxisFit
    grid: GriddedErrors
    input: str

    def profile_dict(self, name, description=None, source=None):
        """Return the profile (schema 1) with a ``fit`` section, as plain data."""
        axes = {}
        for ax, fit in zip(AXES, (self.north, self.east)):
            p = fit.params
            axes[ax] = {'delta': _num(p.delta),
                        'phi': [_num(v) for v in p.phi],
                        'sigma_w': _num(p.sigma_w)}
        return {
            'schema': 1,
            'name': name,
            'description': description or f'fitted to {self.input}',
            'source': source or f'gps_error calibrate {self.input}',
            'rate_hz': self.grid.rate_hz,
            'axes': axes,
            'fit': {
                'method': 'Yule-Walker, biased autocovariance pooled over '
                          'segments',
                'input': self.input,
                'samples': self.grid.n,
                'segments': len(self.grid.segments),
                'time_span_s': float(self.grid.span_s),
                'order_selection': {ax: f.evidence() for ax, f in
                                    zip(AXES, (self.north, self.east))},
            },
        }


def calibrate(trace, order=None, max_order=DEFAULT_MAX_ORDER, rate_hz=1.0):
    """Fit both axes of ``trace``; return a :class:`CalibrationResult`."""
    grid = errors_on_grid(trace, rate_hz)
    fits = [fit_axis(grid.axis(a), order, max_order, axis=ax)
            for a, ax in enumerate(AXES)]
    return CalibrationResult(fits[0], fits[1], grid, trace.name)


def write_profile(path, profile, tool='calibrate'):
    """Write a profile mapping as YAML (keys in schema order)."""
    with open(path, 'w', encoding='utf-8') as f:
        f.write(f'# Written by gps_error {tool}.\n')
        yaml.safe_dump(profile, f, sort_keys=False, default_flow_style=None,
                       width=100)
