"""Yule-Walker estimation of AR(p) parameters (the paper's calibration)."""

from dataclasses import dataclass

import numpy as np
from scipy import linalg

from .ar_model import AxisParams, is_stationary, ModelError
from .stats import autocovariance


@dataclass(frozen=True)
class YuleWalkerFit:
    """
    Result of a Yule-Walker fit of one axis.

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
    def delta(self):
        """Return the constant term ``(1 - sum phi) * mean`` (Eq. 3)."""
        return float((1.0 - self.phi.sum()) * self.mean)

    def axis_params(self):
        """Return the fit as :class:`AxisParams` (validated)."""
        return AxisParams(self.delta, tuple(self.phi), self.sigma_w)


def yule_walker(x, order):
    """
    Fit AR(``order``) to ``x`` by Yule-Walker with the biased autocovariance.

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
    phi = linalg.solve_toeplitz(acv[:order], acv[1:order + 1])
    var = acv[0] - phi @ acv[1:order + 1]
    if not is_stationary(phi) or not var > 0:
        raise ModelError(f'the Yule-Walker fit phi={phi.round(4).tolist()} is '
                         f'not stationary')
    return YuleWalkerFit(phi=phi, sigma_w=float(np.sqrt(var)),
                         mean=float(x.mean()), n=int(x.size))
