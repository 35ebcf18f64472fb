"""
Yule-Walker estimation of AR(p), and the paper's choice of the order.

One solver (:func:`solve_yule_walker`) from a biased autocovariance, used
by calibration (pooled over segments, with the PACF order rule) and by
:func:`yule_walker` for one series.

The order is the paper's choice unless fixed: the largest lag up to
``max_order`` whose partial autocorrelation lies outside the significance
bound ``z / sqrt(n)`` (z = 1.96, 5 %). BIC's choice is recorded beside it.
"""

from dataclasses import dataclass
import math
from typing import Any, Optional, Sequence

import numpy as np
from scipy import linalg

from gps_error_ros.fit.autocorrelation import (autocovariance, durbin_levinson,
                                               pooled_autocovariance)
from gps_error_ros.model.ar_model import AxisParams, is_stationary, MAX_ORDER, ModelError
from gps_error_ros.model.state import FloatArray, Numbers

PACF_Z = 1.959963984540054
DEFAULT_MAX_ORDER = 10


class CalibrationError(ValueError):
    """Data that cannot give a profile (too few samples, not stationary)."""


def _num(value: float, digits: int = 6) -> float:
    """Return ``value`` as a plain float rounded for a YAML file."""
    return round(float(value), digits)


def solve_yule_walker(acv: FloatArray, order: int) -> tuple[FloatArray, float]:
    """
    Return (phi, innovation variance) of AR(``order``) from autocovariances.

    ``acv`` holds lags 0..order of a biased autocovariance. Raises
    :class:`ModelError` when the fit is not stationary.
    """
    phi = linalg.solve_toeplitz(acv[:order], acv[1:order + 1])
    var = acv[0] - phi @ acv[1:order + 1]
    if not is_stationary(phi) or not var > 0:
        raise ModelError(f'the Yule-Walker AR({order}) fit phi='
                         f'{np.round(phi, 4).tolist()} is not stationary')
    return phi, float(var)


@dataclass(frozen=True)
class YuleWalkerFit:
    """
    Result of a Yule-Walker fit of one series.

    Attributes
    ----------
    phi : numpy.ndarray
        AR coefficients phi_1..phi_p.
    sigma_w : float
        Innovation standard deviation implied by the fit.
    mean : float
        Sample mean (the process mean m of Eq. 3).
    n : int
        Samples used.

    """

    phi: np.ndarray
    sigma_w: float
    mean: float
    n: int

    @property
    def delta(self) -> float:
        """Return the constant term ``(1 - sum phi) * mean`` (Eq. 3)."""
        return float((1.0 - self.phi.sum()) * self.mean)

    def axis_params(self) -> AxisParams:
        """Return the fit as :class:`AxisParams` (validated)."""
        return AxisParams(self.delta, tuple(self.phi), self.sigma_w)


def yule_walker(x: Numbers, order: int) -> YuleWalkerFit:
    """
    Fit AR(``order``) to one series by Yule-Walker (biased autocovariance).

    Parameters
    ----------
    x
        The series, without gaps.
    order
        The AR order, at least 1.

    Returns
    -------
    YuleWalkerFit
        phi, sigma_w, the mean and the sample count.

    Raises
    ------
    ValueError
        When ``x`` is too short or not finite, or the fit is not stationary.

    """
    x = np.asarray(x, dtype=float)
    if order < 1:
        raise ValueError(f'order must be >= 1, got {order}')
    if x.size < 2 * order + 2:
        raise ValueError(f'{x.size} samples are too few for order {order} '
                         f'(need at least {2 * order + 2})')
    if not np.all(np.isfinite(x)):
        raise ValueError('samples must be finite')
    acv = autocovariance(x, order)
    if acv[0] <= 0:
        raise ValueError('the series is constant: no AR model can be fitted')
    phi, var = solve_yule_walker(acv, order)
    return YuleWalkerFit(phi=phi, sigma_w=float(np.sqrt(var)),
                         mean=float(x.mean()), n=int(x.size))


@dataclass(frozen=True)
class AxisFit:
    """Calibration of one axis, with the order-selection evidence."""

    params: AxisParams
    mean: float
    pacf: tuple[float, ...]
    pacf_bound: float
    pacf_order: int
    bic: tuple[float, ...]
    bic_order: int
    fixed_order: bool

    def evidence(self) -> dict[str, Any]:
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


def fit_axis(segments: Sequence[Numbers], order: Optional[int] = None,
             max_order: int = DEFAULT_MAX_ORDER, axis: str = 'axis') -> AxisFit:
    """Fit one axis from its segments (see the module docstring)."""
    if order is not None and order < 1:
        raise CalibrationError(f'order must be >= 1, got {order}')
    if max_order < 1:
        raise CalibrationError(f'max_order must be >= 1, got {max_order}')
    if max(order or 0, max_order) > MAX_ORDER:
        raise CalibrationError(f'order and max_order must be <= {MAX_ORDER} '
                               f'(the largest AR order a profile may have), got '
                               f'{max(order or 0, max_order)}')
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
    try:
        phi, sigma2 = solve_yule_walker(acv, p)
    except ModelError as exc:
        raise CalibrationError(f'{axis}: {exc}') from None
    try:
        params = AxisParams((1 - phi.sum()) * mean, tuple(phi),
                            float(np.sqrt(sigma2)))
    except ModelError as exc:
        raise CalibrationError(f'{axis}: {exc}') from None
    return AxisFit(params, float(mean), tuple(pacf[:max_order]), bound,
                   pacf_order, tuple(bic), bic_order, order is not None)
