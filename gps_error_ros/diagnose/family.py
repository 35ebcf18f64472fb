"""
The test family of the diagnosis: what the innovations still carry.

First round, on the base model's training innovations (ten tests, Holm's
step-down procedure at family-wise level ``FAMILY_ALPHA``, ten fifteenths
of the diagnosis's ``ALPHA``; the retest has the rest):

- ``cross_axis_correlation``: lag-0 north-east correlation
  (heteroscedasticity-robust z: changing variance alone does not reject);
- ``motion_dependence``: does the error follow a lag in [0, 5] s: for each
  L in 1..5 s the likelihood ratio of ``b x (truth(t - L) - truth(t))``,
  ``b >= 0`` (chi-bar-squared), the largest against its max-T law over
  the lags' correlated scores (:func:`motion_test`);
- ``kurtosis``: Mardia's bivariate kurtosis against its Gaussian value;
- ``squared_persistence``: Ljung-Box over lags 1-10 of the *ranks* of the
  squared Mahalanobis innovations (ranks keep the level under heavy tails);
- ``squared_oscillation``: the most negative of those autocorrelations
  (one-sided, Sidak over the lags): regimes and tails only make squares
  correlate positively, so this is periodic variance;
- ``serial_north``, ``serial_east``: heteroscedasticity-robust Ljung-Box over
  lags 1-30 of each axis's innovations (30 - p degrees of freedom);
- ``travel_frame``: does the innovation covariance turn with the direction
  of travel (:func:`travel_frame_test`): a walk along one street cannot
  show it, a walk that turns corners can.
- ``periodicity``: a cycle of P steps in the innovations' mean or variance
  (:func:`periodicity_test`), P in ``PERIODS``, against blocks of the
  innovations with their phases shifted at random.
- ``jump_reversal``: do large innovations come in pairs of opposite sign a
  few steps apart (:func:`jump_reversal_test`): a fix that jumps away and
  back leaves one at each end, a heavy-tailed innovation or a burst of
  variance leaves large ones of unrelated signs.

Second round (:func:`retest`), on the extended model's standardised
innovations: serial and cross correlation, persistence, and the calibration
of the predictive distribution (PIT of the Mahalanobis radius).
"""

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
import math
from typing import Any, Optional

import numpy as np
from scipy import stats

from gps_error_ros.diagnose.common import (FAMILY_ALPHA, MOTION_TEST_LAGS, Orders, PERIODS,
                                           PERSIST_LAGS, SERIAL_LAGS)
from gps_error_ros.diagnose.findings import Outcome
from gps_error_ros.diagnose.laws import mahalanobis, robust_cov
from gps_error_ros.diagnose.models import FittedModel
from gps_error_ros.fit.autocorrelation import segment_acf
from gps_error_ros.model.ar_model import AXES
from gps_error_ros.model.state import FloatArray, IntArray, Numbers


def ljung_box(x: FloatArray, seg: IntArray, max_lag: int, dof: int
              ) -> tuple[float, float, FloatArray]:
    """Return (Q, p-value, acf) of the Ljung-Box test."""
    n = len(x)
    acf = segment_acf(x, seg, max_lag)
    q = n * (n + 2) * np.sum(acf ** 2 / (n - np.arange(1, max_lag + 1)))
    return float(q), float(stats.chi2.sf(q, max(1, dof))), acf


def _lag_products(x: FloatArray, y: FloatArray, seg: IntArray, k: int) -> FloatArray:
    """Return x_t * y_{t-k} over pairs within one segment (deviations)."""
    if k == 0:
        return x * y
    same = seg[k:] == seg[:-k]
    return x[k:][same] * y[:-k][same]


def robust_portmanteau(x: FloatArray, seg: IntArray, max_lag: int,
                       dof: int) -> tuple[float, float, FloatArray]:
    """
    Return Q, its p-value and the ACF: a heteroscedasticity-robust Ljung-Box.

    Q = sum_k z_k^2, z_k = sum x_t x_{t-k} / sqrt(sum (x_t x_{t-k})^2),
    chi-squared with ``dof`` degrees of freedom. Variance that changes in
    time (regimes, tails) does not make it reject serial correlation that is
    not there.
    """
    d = np.asarray(x, dtype=float) - np.mean(x)
    acf = segment_acf(d, seg, max_lag)
    z = np.zeros(max_lag)
    for k in range(1, max_lag + 1):
        p = _lag_products(d, d, seg, k)
        den = math.sqrt(float(p @ p))
        z[k - 1] = p.sum() / den if den > 0 else 0.0
    q = float(z @ z)
    return q, float(stats.chi2.sf(q, max(1, dof))), acf


def robust_correlation_test(x: Numbers, y: Numbers) -> tuple[float, float]:
    """Return (correlation, p-value) of a heteroscedasticity-robust z test."""
    x = np.asarray(x) - np.mean(x)
    y = np.asarray(y) - np.mean(y)
    p = x * y
    den = math.sqrt(float(p @ p))
    z = p.sum() / den if den > 0 else 0.0
    rho = float(p.sum() / math.sqrt(float(x @ x) * float(y @ y)))
    return rho, float(2 * stats.norm.sf(abs(z)))


def holm(pvalues: Mapping[str, float], alpha: float = FAMILY_ALPHA,
         given: Mapping[str, float] | None = None) -> tuple[dict[str, bool], dict[str, float]]:
    """
    Return Holm's reject decisions and adjusted p-values (dict by name).

    ``given``: name -> adjusted p of tests already rejected by the same
    step-down over the same tests on other innovations (the family with the
    jumps in, :func:`~.pipeline.run_family`). They count as the first steps
    taken: the others are stepped down over the ``m - g`` left, and their
    adjusted p is at least the givens' (rejected iff adjusted <= alpha holds
    throughout). A given test whose null is false costs nothing; one whose
    null is true was already a family-wise error where it was rejected.
    """
    given = dict(given or {})
    names = sorted((k for k in pvalues if k not in given), key=lambda k: pvalues[k])
    m = len(names)
    adjusted = dict(given)
    reject = {k: True for k in given}
    running, stop = max(given.values(), default=0.0), False
    for i, k in enumerate(names):
        running = max(running, min(1.0, (m - i) * pvalues[k]))
        adjusted[k] = running
        stop = stop or pvalues[k] > alpha / (m - i)
        reject[k] = not stop
    return reject, adjusted


def holm_tests(tests: Mapping[str, Outcome], alpha: float = FAMILY_ALPHA,
               given: Mapping[str, float] | None = None
               ) -> tuple[dict[str, Outcome], dict[str, bool], dict[str, float]]:
    """
    Return (``tests`` each with its Holm-adjusted p and decision, reject, adjusted).

    ``tests``: name -> a test; those returned are new records (a test shared
    by two families keeps each family's decision). ``given``: as
    :func:`holm`; those tests are marked ``given``.
    """
    reject, adjusted = holm({k: v.p_value for k, v in tests.items()}, alpha, given)
    return ({k: v.decided(adjusted[k], reject[k], k in (given or {}))
             for k, v in tests.items()}, reject, adjusted)


#: Draws of the motion test's max-T law (its p-value is at least 1 / (draws + 1)).
MOTION_DRAWS = 200_000


def motion_test(lrs: Numbers, corr: FloatArray | None = None, draws: int = MOTION_DRAWS,
                seed: int = 0) -> Outcome:
    """
    Return the motion-dependence test from the likelihood ratios per lag.

    Each ratio is chi-bar-squared, the square of the positive part of a
    Gaussian score. Over the lags the largest ratio is referred to the law
    of the largest of those squares, the scores' correlation ``corr`` (from
    :func:`~.mean.motion_correlation`) drawn ``draws`` times (max-T); the
    lags' probes overlap, so this is sharper than Bonferroni, which bounds
    it and is used without ``corr``.
    """
    ps = [0.5 * float(stats.chi2.sf(lr, 1)) if lr > 1e-9 else 1.0 for lr in lrs]
    i = int(np.argmin(ps))
    p = min(1.0, len(ps) * ps[i])
    how = 'Bonferroni over L'
    if corr is not None and ps[i] < 1.0:
        w, v = np.linalg.eigh(np.asarray(corr, dtype=float))
        z = np.random.default_rng(seed).standard_normal((draws, len(w))) @ \
            (v * np.sqrt(np.maximum(w, 0.0))).T
        top = np.max(np.maximum(z, 0.0) ** 2, axis=1)
        p = min(p, (1 + int(np.sum(top >= lrs[i]))) / (draws + 1))
        how = 'the largest over L against its max-T law'
    return Outcome(float(lrs[i]), p,
                   f'likelihood ratio for an error component b x (truth L s '
                   f'ago - truth now), b >= 0, against none, for L in '
                   f'{list(MOTION_TEST_LAGS)} (chi-bar-squared each, {how})',
                   {'at_lag_s': MOTION_TEST_LAGS[i]})


#: Circular shifts of the travel-frame test (its p-value is at least 1/1000).
TRAVEL_SHIFTS = 1000


def travel_frame_test(r: FloatArray, heading: FloatArray | None,
                      shifts: int = TRAVEL_SHIFTS) -> Outcome:
    """
    Return the test that the innovation covariance turns with the travel.

    A covariance ``R(theta) diag(a, c) R(theta)'`` has ``E[(rn^2 - re^2)/2] =
    k cos 2theta + m`` and ``E[rn re] = k sin 2theta + m'`` with ``k = (a -
    c) / 2``; a covariance fixed in north/east axes has ``k = 0`` whatever the
    direction. The statistic ``S`` is the covariance of ((rn^2 - re^2)/2,
    rn re) with (cos 2theta, sin 2theta). Its null distribution comes from
    the same innovations paired with the directions circularly shifted
    (``shifts`` shifts evenly spaced over the whole cycle, the unshifted one
    among them, so that the p-value is the rank of ``S`` in a group of
    shifts): that keeps the persistence of each (variance that lasts, long
    legs of one direction) and breaks only their link. Rotation invariant;
    no power when the direction does not change.
    """
    if heading is None:
        raise ValueError('the travel-frame test needs each sample\'s direction of travel')
    d = r - r.mean(axis=0)
    u, v = 0.5 * (d[:, 0] ** 2 - d[:, 1] ** 2), d[:, 0] * d[:, 1]
    u, v = u - u.mean(), v - v.mean()
    c2, s2 = np.cos(2 * heading), np.sin(2 * heading)
    c2, s2 = c2 - c2.mean(), s2 - s2.mean()
    n = len(r)
    what = ('covariance of the innovations\' squares with twice the direction '
            'of travel, against circular shifts of the directions, two-sided')
    spread = float(np.mean(c2 ** 2 + s2 ** 2))
    k_shifts = min(shifts, n)
    if spread < 1e-9 or k_shifts < 20:
        return Outcome(0.0, 1.0, what, {'shifts': k_shifts})
    stat = float(np.mean(u * c2 + v * s2))
    offsets = (np.arange(k_shifts) * n) // k_shifts          # 0 (unshifted) first
    null = np.array([np.mean(u * np.roll(c2, o) + v * np.roll(s2, o)) for o in offsets])
    p = int(np.sum(np.abs(null) >= abs(stat) * (1 - 1e-12))) / k_shifts
    return Outcome(stat, float(p), what,
                   {'half_difference_m2': stat / spread, 'shifts': int(k_shifts)})


#: Steps per block whose phases :func:`periodicity_test` shifts together.
CYCLE_BLOCK = 60
#: Draws of the shifted phases (the p-value is at least 1 / (draws + 1)).
CYCLE_DRAWS = 400


def _phase_spread(series: Sequence[FloatArray], phase: IntArray, period: int) -> list[float]:
    """Return the between-phase sum of squares (sum_j n_j mean_j^2) of each series."""
    counts = np.bincount(phase, minlength=period)
    ok = counts > 0
    return [float(np.sum(np.bincount(phase, weights=x, minlength=period)[ok] ** 2
                         / counts[ok])) for x in series]


def periodicity_test(r: FloatArray, seg: IntArray, steps: IntArray | None,
                     periods: Sequence[int] = PERIODS, block: int = CYCLE_BLOCK,
                     draws: int = CYCLE_DRAWS, seed: int = 0) -> Outcome:
    """
    Return the test for a cycle of ``P`` steps in the innovations ``r`` (n, 2).

    ``steps`` (n,) is each innovation's step on the grid (its phase is
    ``steps % P``). For each P two statistics: the between-phase sum of
    squares of the standardised innovations, summed over the axes (a cycle
    in the mean), and that of the standardised ranks of their squared
    Mahalanobis radius (a cycle in the variance). Their null distribution
    comes from the same innovations with the phases of each block of
    ``block`` steps (within a segment) shifted by a random amount: that
    keeps everything within a block (persistence of variance, serial
    correlation) and breaks only the alignment of phases from block to
    block. Each statistic is standardised by its null mean and SD; the test
    takes the largest over P and the two kinds (the estimated period)
    against the largest of each draw.

    Long because it is one test: statistics, null draws, p-value.
    """
    what = (f'cycle of P steps in the innovations\' mean or variance, P in '
            f'{periods[0]}-{periods[-1]}, against blocks of {block} steps with '
            f'their phases shifted at random ({draws} draws)')
    n = len(r)
    if n < 4 * max(periods):
        return Outcome(0.0, 1.0, what, {'at_period': 0, 'in': 'none'})
    d = r - r.mean(axis=0)
    z = d / d.std(axis=0)
    dm = stats.rankdata(mahalanobis(d, np.cov(d.T, bias=True)))
    series = (z[:, 0], z[:, 1], (dm - dm.mean()) / dm.std())
    starts = np.r_[0, np.flatnonzero(np.diff(seg) != 0) + 1]
    pos = np.arange(n) - np.repeat(starts, np.diff(np.r_[starts, n]))
    blk = np.ravel(np.unique(np.stack([seg, pos // block], axis=1), axis=0,
                             return_inverse=True)[1])
    u = np.random.default_rng(seed).random((draws, int(blk.max()) + 1))
    steps = np.asarray(steps, dtype=np.int64)
    obs, null = np.empty((len(periods), 2)), np.empty((draws, len(periods), 2))
    for i, p in enumerate(periods):
        a, b, c = _phase_spread(series, steps % p, p)
        obs[i] = a + b, c
        for k in range(draws):
            a, b, c = _phase_spread(series, (steps + (u[k] * p).astype(np.int64)[blk]) % p, p)
            null[k, i] = a + b, c
    mu, sd = null.mean(axis=0), np.maximum(null.std(axis=0), 1e-12)
    zobs, znull = (obs - mu) / sd, ((null - mu) / sd).reshape(draws, -1).max(axis=1)
    bi, bj = (int(v) for v in np.unravel_index(int(np.argmax(zobs)), zobs.shape))
    p_value = (1 + int(np.sum(znull >= zobs[bi, bj]))) / (draws + 1)
    return Outcome(float(zobs[bi, bj]), float(p_value), what,
                   {'at_period': int(periods[bi]), 'in': ('mean', 'variance')[bj]})


#: Large innovations at most this many samples apart pair up (jump_reversal).
REVERSAL_WINDOW = 10
#: A squared Mahalanobis radius above this many times its robust scale is large
#: (the 0.999 quantile of chi-squared with 2 degrees of freedom).
REVERSAL_THRESHOLD = 13.8
#: Draws of the random signs (the p-value is at least 1 / (draws + 1)).
REVERSAL_DRAWS = 2000


def robust_whitened(r: FloatArray) -> FloatArray:
    """Return ``r`` centred and whitened by a covariance that gross outliers do not inflate."""
    d = r - np.median(r, axis=0)
    return np.linalg.solve(np.linalg.cholesky(robust_cov(r)), d.T).T


def jump_reversal_test(r: FloatArray, seg: IntArray, window: int = REVERSAL_WINDOW,
                       draws: int = REVERSAL_DRAWS, seed: int = 0) -> Outcome:
    """
    Return the test for jumps of the fix that come back (the ``outliers`` effect).

    A jump of the reported fix by ``o`` leaves an innovation of about ``o``
    where it starts and about ``-o`` (times the AR's sum) where it ends, so
    large innovations pair up with opposite directions. The statistic is
    ``-sum w cos`` over pairs of large innovations (squared radius above
    ``REVERSAL_THRESHOLD`` robust units) at most ``window`` samples apart in
    one segment, ``w = 1 / sqrt(d_a d_b)`` with ``d`` the number of pairs
    an innovation is in: a burst of m large innovations makes m(m - 1) / 2
    pairs of signs at random, and unweighted they outweighed the isolated
    pairs of single jumps. Its null multiplies every large innovation by an
    independent random sign: exact for any centrally symmetric law of the
    innovations, however their variance clusters in time (tails, regimes).
    """
    what = (f'large innovations in opposite directions within {window} samples '
            f'(pairs in bursts weighted down), against random signs ({draws} draws)')
    z = robust_whitened(r)
    q = np.sum(z * z, axis=1)
    big = np.flatnonzero(q > REVERSAL_THRESHOLD * np.median(q) / math.log(4.0))
    i, j = np.triu_indices(big.size, 1)
    near = (big[j] - big[i] <= window) & (seg[big[j]] == seg[big[i]])
    i, j = i[near], j[near]
    if not i.size:
        return Outcome(0.0, 1.0, what, {'pairs': 0, 'large': int(big.size)})
    u = z[big] / np.sqrt(q[big])[:, None]
    degree = np.bincount(np.r_[i, j], minlength=big.size)
    cos = np.sum(u[i] * u[j], axis=1) / np.sqrt(degree[i] * degree[j])
    stat = float(-cos.sum())
    signs = np.random.default_rng(seed).choice([-1.0, 1.0], size=(draws, big.size))
    null = -(signs[:, i] * signs[:, j]) @ cos
    p = (1 + int(np.sum(null >= stat - 1e-12))) / (draws + 1)
    return Outcome(stat, float(p), what, {'pairs': int(i.size), 'large': int(big.size)})


def innovation_tests(r: FloatArray, seg: IntArray, orders: Orders,
                     r_axes: FloatArray | None = None) -> dict[str, Outcome]:
    """
    Return the first-round test statistics and p-values (dict by name).

    ``r_axes``: the innovations north/east when ``r`` is in another frame
    (the travel's). The serial tests run on them: the AR part is fitted per
    north/east axis, so only there are its first autocorrelations held near
    zero, which the tests' degrees of freedom allow for.
    """
    n = len(r)
    out = {}
    rho, p = robust_correlation_test(r[:, 0], r[:, 1])
    out['cross_axis_correlation'] = Outcome(
        rho, p, 'lag-0 north-east correlation of the innovations, heteroscedasticity-robust z')
    cov = np.cov(r.T, bias=True)
    dm = mahalanobis(r - r.mean(axis=0), cov)
    b2 = float(np.mean(dm ** 2))
    zk = (b2 - 8.0) / math.sqrt(64.0 / n)
    out['kurtosis'] = Outcome(b2, float(stats.norm.sf(zk)),
                              "Mardia's bivariate kurtosis, one-sided", {'gaussian_value': 8.0})
    ranks = stats.rankdata(dm)
    q, p, acf = ljung_box(ranks, seg, PERSIST_LAGS, PERSIST_LAGS)
    out['squared_persistence'] = Outcome(
        q, p, f'Ljung-Box, lags 1-{PERSIST_LAGS}, ranks of squared Mahalanobis innovations',
        {'acf': [round(v, 4) for v in acf]})
    # Regimes and tails can only make the squares correlate positively; a
    # significantly negative autocorrelation is periodic variance instead.
    k = int(np.argmin(acf))
    z = -acf[k] * math.sqrt(n)
    p_one = float(stats.norm.sf(z))
    out['squared_oscillation'] = Outcome(
        float(acf[k]), float(1.0 - (1.0 - p_one) ** PERSIST_LAGS),
        f'most negative autocorrelation of the ranks of the squared innovations, '
        f'lags 1-{PERSIST_LAGS}, one-sided, Sidak over lags', {'at_lag': k + 1})
    out.update(serial_tests(r if r_axes is None else r_axes, seg, orders))
    return out


def serial_tests(r: FloatArray, seg: IntArray, orders: Orders) -> dict[str, Outcome]:
    """Return the serial tests of north/east innovations ``r`` (an AR of ``orders`` fitted)."""
    out = {}
    for a, ax in enumerate(AXES):
        q, p, acf = robust_portmanteau(r[:, a], seg, SERIAL_LAGS,
                                       SERIAL_LAGS - orders[a])
        top = np.argsort(-np.abs(acf))[:3] + 1
        out[f'serial_{ax}'] = Outcome(
            q, p, f'heteroscedasticity-robust Ljung-Box, lags 1-{SERIAL_LAGS}, '
                  f'{SERIAL_LAGS - orders[a]} dof', {'largest_acf_lags': [int(v) for v in top]})
    return out


def standardised(model: FittedModel, r: FloatArray, pred: FloatArray) -> FloatArray:
    """Return innovations whitened by the model's predictive covariance."""
    scale2 = pred @ (model.law.scales ** 2)
    chol = np.linalg.cholesky(model.law.cov)
    z = np.linalg.solve(chol, r.T).T
    return z / np.sqrt(scale2)[:, None]


def pit_radial(model: FittedModel, r: FloatArray, pred: FloatArray) -> FloatArray:
    """Return the PIT of each innovation's Mahalanobis radius under the model."""
    dm = mahalanobis(r, model.law.cov)
    u = np.zeros(len(r))
    for j, s in enumerate(model.law.scales):
        x = dm / (s * s)
        if math.isfinite(model.law.dof):
            nu = model.law.dof
            cdf = stats.f.cdf(x * nu / (nu - 2.0) / 2.0, 2, nu)
        else:
            cdf = stats.chi2.cdf(x, 2)
        u += pred[:, j] * cdf
    return u


def retest(model: FittedModel, r: FloatArray, seg: IntArray, pred: FloatArray,
           r_axes: FloatArray | None = None, serial: bool = True) -> dict[str, Outcome]:
    """
    Test the extended model's own innovations; return the test dict.

    ``r_axes``: its innovations north/east when ``r`` is in the law's frame
    along/across the travel (the serial tests run on them, as in the first
    round); ``serial``: whether to run the serial tests at all.
    """
    z = standardised(model, r, pred)
    out: dict[str, Outcome] = {}
    rho, p = robust_correlation_test(z[:, 0], z[:, 1])
    out['cross_axis_correlation'] = Outcome(rho, p)
    u = pit_radial(model, r, pred)
    ranks = stats.rankdata(u)
    q, p, _ = ljung_box(ranks, seg, PERSIST_LAGS, PERSIST_LAGS)
    out['squared_persistence'] = Outcome(q, p)
    ks = stats.kstest(np.clip(u, 0, 1), 'uniform')
    out['pit_uniformity'] = Outcome(float(ks.statistic), float(ks.pvalue),
                                    'Kolmogorov-Smirnov of the PIT of the Mahalanobis radius')
    if r_axes is not None:
        z = r_axes / np.sqrt(pred @ (model.law.scales ** 2))[:, None]
    if serial:
        out.update(serial_tests(z, seg, model.orders))
    return out


@dataclass
class FamilyResult:
    """The first-round tests, their Holm decisions, and what they ran on."""

    tests: dict[str, Outcome]           # by name, with Holm's decisions
    reject: dict[str, bool]
    adjusted: dict[str, float]
    lag_s: Optional[float] = None    # the lag removed before the law's tests, if any
    jump_orders: tuple[int, ...] = ()   # with jumps: the AR orders without them (run_family)
    base_residuals: tuple[Any, ...] = ()      # (r, seg) of the base model on the training part
