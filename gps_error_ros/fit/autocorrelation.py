"""
Autocovariance and autocorrelation: the one implementation, and its error.

Series with gaps come as segments; products are taken only within a
segment. Also the partial autocorrelation (Durbin-Levinson) and the
large-sample standard errors of the sample ACF and variance.
"""

from typing import Any, Optional, Sequence

import numpy as np

from gps_error_ros.model.state import FloatArray, Numbers


def pooled_autocovariance(segments: Sequence[Numbers], max_lag: int,
                          mean: Numbers = None) -> tuple[FloatArray, int, Any]:
    """
    Return the pooled biased autocovariance at lags 0..max_lag, n and the mean.

    Products are taken only within a segment (a gap is never bridged), about
    the pooled mean (or ``mean``), and divided by the total sample count at
    every lag: the biased estimator, whose Toeplitz matrices stay positive
    semi-definite as Yule-Walker needs.
    """
    n = sum(len(s) for s in segments)
    if mean is None:
        mean = sum(float(np.sum(s)) for s in segments) / n
    acv = np.zeros(max_lag + 1)
    if len(segments) == 1:
        joined = np.asarray(segments[0], dtype=float) - mean
    else:
        # the segments one after another, max_lag zeros between them: a product
        # across a gap is then zero, and each lag is one dot product
        gap = np.zeros(max_lag)
        parts = [p for s in segments for p in (np.asarray(s, dtype=float) - mean, gap)]
        joined = np.concatenate(parts[:-1]) if parts else np.zeros(0)
    longest = max((len(s) for s in segments), default=0)
    for k in range(min(max_lag, longest - 1) + 1):
        acv[k] = joined[:joined.size - k] @ joined[k:]
    return acv / n, n, mean


def about_recording_means(segments: Sequence[Numbers],
                          recording: Optional[Sequence[Any]] = None) -> Sequence[Numbers]:
    """
    Return ``segments`` each less the mean of its recording (``recording``: a label each).

    Recordings differ in their bias; about one mean pooled over several, that
    difference reads as persistence at every lag. So the autocorrelation of
    several recordings is taken with each about its own mean, then pooled.
    With one recording (or ``recording`` None) the segments are returned as
    they are.
    """
    if recording is None or len(set(recording)) < 2:
        return segments
    out = [np.asarray(s, dtype=float) for s in segments]
    for r in set(recording):
        own = [i for i, lab in enumerate(recording) if lab == r]
        mean = np.concatenate([out[i] for i in own]).mean(axis=0)
        for i in own:
            out[i] = out[i] - mean
    return out


def pooled_acf(segments: Sequence[Numbers], max_lag: int) -> FloatArray:
    """Return the pooled autocorrelation at lags 0..max_lag (see above)."""
    acv, _, _ = pooled_autocovariance(segments, max_lag)
    return acv / acv[0]


def segment_acf(x: Numbers, seg: Numbers, max_lag: int) -> FloatArray:
    """
    Return the pooled autocorrelation of ``x`` at lags 1..max_lag.

    ``seg`` labels each sample's segment (runs of equal labels); zeros when
    ``x`` is constant.
    """
    x = np.asarray(x, dtype=float)
    seg = np.asarray(seg)
    cuts = np.flatnonzero(seg[1:] != seg[:-1]) + 1
    acv, _, _ = pooled_autocovariance(np.split(x, cuts), max_lag)
    if not acv[0] > 0:
        return np.zeros(max_lag)
    return acv[1:] / acv[0]


def autocovariance(x: Numbers, max_lag: int) -> FloatArray:
    """
    Return the biased sample autocovariance of one series at lags 0..max_lag.

    The divisor is ``n`` at every lag (one segment of
    :func:`pooled_autocovariance`).
    """
    x = np.asarray(x, dtype=float)
    n = x.size
    if n < 2:
        raise ValueError(f'need at least 2 samples, got {n}')
    if not 0 <= max_lag < n:
        raise ValueError(f'max_lag must be in [0, {n - 1}], got {max_lag}')
    return pooled_autocovariance([x], max_lag)[0]


def autocorrelation(x: Numbers, max_lag: int) -> FloatArray:
    """Return the sample autocorrelation of ``x`` at lags 0..max_lag."""
    acv = autocovariance(x, max_lag)
    return acv / acv[0]


def durbin_levinson(acv: FloatArray, max_lag: int) -> tuple[FloatArray, FloatArray]:
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


def bartlett_acf_se(rho: Numbers, lag: int, n: int) -> float:
    """
    Return Bartlett's standard error of the sample autocorrelation.

    Parameters
    ----------
    rho
        The true autocorrelation at lags 0..L, with L well past the point
        where it has decayed (L >= lag + the decay length).
    lag
        The lag whose estimate is considered.
    n
        Sample size.

    Returns
    -------
    float
        The standard error of the sample autocorrelation at ``lag``.

    Notes
    -----
    Bartlett (1946): ``n Var(r_k) = sum_j (rho_{j+k}^2 + rho_{j-k} rho_{j+k}
    - 4 rho_k rho_j rho_{j+k} + 2 rho_j^2 rho_k^2)`` over all integers j.

    """
    rho = np.asarray(rho, dtype=float)
    L = rho.size - 1

    def r(j: int) -> float:
        j = abs(j)
        return rho[j] if j <= L else 0.0

    k = lag
    total = 0.0
    for j in range(-L, L + 1):
        total += (r(j + k) ** 2 + r(j - k) * r(j + k)
                  - 4 * r(k) * r(j) * r(j + k) + 2 * r(j) ** 2 * r(k) ** 2)
    return float(np.sqrt(total / n))


def variance_se(rho: Numbers, n: int, variance: float) -> float:
    """
    Return the large-sample standard error of the sample variance.

    For a Gaussian linear process, ``n Var(s^2) = 2 gamma_0^2 sum_j rho_j^2``
    over all integers j.
    """
    rho = np.asarray(rho, dtype=float)
    return float(variance * np.sqrt(2.0 * (1.0 + 2.0 * np.sum(rho[1:] ** 2)) / n))
