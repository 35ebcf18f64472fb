"""Time-series statistics: sample autocorrelation and its sampling error."""

import numpy as np


def autocovariance(x, max_lag):
    """
    Return the biased sample autocovariance of ``x`` at lags 0..max_lag.

    The divisor is ``n`` at every lag (the estimator whose autocovariance
    matrices are positive semi-definite, as Yule-Walker needs).
    """
    x = np.asarray(x, dtype=float)
    n = x.size
    if n < 2:
        raise ValueError(f'need at least 2 samples, got {n}')
    if not 0 <= max_lag < n:
        raise ValueError(f'max_lag must be in [0, {n - 1}], got {max_lag}')
    d = x - x.mean()
    return np.array([d[:n - k] @ d[k:] / n for k in range(max_lag + 1)])


def autocorrelation(x, max_lag):
    """Return the sample autocorrelation of ``x`` at lags 0..max_lag."""
    acv = autocovariance(x, max_lag)
    return acv / acv[0]


def bartlett_acf_se(rho, lag, n):
    """
    Return Bartlett's standard error of the sample autocorrelation.

    Parameters
    ----------
    rho : array
        The true autocorrelation at lags 0..L, with L well past the point
        where it has decayed (L >= lag + the decay length).
    lag : int
        The lag whose estimate is considered.
    n : int
        Sample size.

    Notes
    -----
    Bartlett (1946): ``n Var(r_k) = sum_j (rho_{j+k}^2 + rho_{j-k} rho_{j+k}
    - 4 rho_k rho_j rho_{j+k} + 2 rho_j^2 rho_k^2)`` over all integers j.

    """
    rho = np.asarray(rho, dtype=float)
    L = rho.size - 1

    def r(j):
        j = abs(j)
        return rho[j] if j <= L else 0.0

    k = lag
    total = 0.0
    for j in range(-L, L + 1):
        total += (r(j + k) ** 2 + r(j - k) * r(j + k)
                  - 4 * r(k) * r(j) * r(j + k) + 2 * r(j) ** 2 * r(k) ** 2)
    return float(np.sqrt(total / n))


def variance_se(rho, n, variance):
    """
    Return the large-sample standard error of the sample variance.

    For a Gaussian linear process, ``n Var(s^2) = 2 gamma_0^2 sum_j rho_j^2``
    over all integers j.
    """
    rho = np.asarray(rho, dtype=float)
    return float(variance * np.sqrt(2.0 * (1.0 + 2.0 * np.sum(rho[1:] ** 2)) / n))
