"""
The innovation law of a model, and its likelihood.

Innovations ``r`` (n, 2) of the mean part are Gaussian with covariance
``cov``, or bivariate Student-t with ``dof`` degrees of freedom scaled to
the same covariance, and with ``K`` variance regimes their scale follows a
hidden Markov chain (``scales``, ``transition``). The likelihood of the
regimes is the forward filter of the chain (vectorised over time as a
parallel prefix product); their fit is Baum-Welch (EM), refined by direct
maximisation when tails are present.
"""

from collections.abc import Callable
from dataclasses import dataclass, field
import math

import numpy as np
from scipy import optimize, special

from gps_error_ros.diagnose.common import DiagnosisError, LOG2PI
from gps_error_ros.diagnose.compiled import kernel
from gps_error_ros.model.effects import stationary_distribution
from gps_error_ros.model.state import FloatArray, IntArray, Numbers


def mahalanobis(r: FloatArray, cov: FloatArray) -> FloatArray:
    """Return the squared Mahalanobis distances of rows of ``r``."""
    return np.einsum('ni,ij,nj->n', r, np.linalg.inv(cov), r)


def robust_cov(r: FloatArray) -> FloatArray:
    """Return the covariance of ``r`` without its gross outliers (3 MADs per axis)."""
    dev = np.abs(r - np.median(r, axis=0))
    mad = np.maximum(1.4826 * np.median(dev, axis=0), 1e-9)
    keep = np.all(dev < 3.0 * mad, axis=1)
    return np.cov(r[keep].T, bias=True) / 0.9733       # a Gaussian trimmed at 3 SD


@dataclass
class Law:
    """The innovation law: covariance, optional Student-t, optional regimes."""

    cov: np.ndarray                       # 2x2 (regime of scale 1)
    dof: float = math.inf
    scales: np.ndarray = field(default_factory=lambda: np.ones(1))
    transition: np.ndarray = field(default_factory=lambda: np.ones((1, 1)))

    @property
    def n_params(self) -> int:
        """Return the number of free parameters of the law."""
        k = self.scales.size
        coupled = self.cov[0, 1] != 0.0
        return 2 + int(coupled) + int(math.isfinite(self.dof)) + \
            (k - 1) + k * (k - 1)


def component_logpdf(r: FloatArray, cov: FloatArray, dof: float, scale2: float) -> FloatArray:
    """Log density of innovations ``r`` (n, 2) under one regime."""
    c = cov * scale2
    det = c[0, 0] * c[1, 1] - c[0, 1] ** 2
    inv = np.array([[c[1, 1], -c[0, 1]], [-c[0, 1], c[0, 0]]]) / det
    q = np.einsum('ni,ij,nj->n', r, inv, r)
    if not math.isfinite(dof):
        return -LOG2PI - 0.5 * math.log(det) - 0.5 * q
    # bivariate t with covariance c: scale matrix c (dof - 2) / dof
    f = dof / (dof - 2.0)
    return (special.gammaln(0.5 * (dof + 2)) - special.gammaln(0.5 * dof)
            - math.log(dof * math.pi) - 0.5 * math.log(det / (f * f))
            - 0.5 * (dof + 2) * np.log1p(q * f / dof))


def _matmul_stack(a: FloatArray, b: FloatArray) -> FloatArray:
    """Return a[t] @ b[t] for stacks laid out (K, K, n): elementwise, fast."""
    k = a.shape[0]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    for i in range(k):
        for j in range(k):
            acc = a[i, 0] * b[0, j]
            for m in range(1, k):
                acc = acc + a[i, m] * b[m, j]
            out[i, j] = acc
    return out


def _prefix_products(mats: FloatArray) -> tuple[FloatArray, FloatArray]:
    """
    Return normalised inclusive prefix products of a (K, K, n) matrix stack.

    ``out[:, :, t] * exp(logc[t])`` equals ``mats[..., 0] @ ... @ mats[..., t]``
    (Hillis-Steele scan: log2(n) vectorised steps).
    """
    mats = mats.copy()
    n = mats.shape[2]
    logc = np.zeros(n)
    d = 1
    while True:
        nrm = mats.max(axis=(0, 1))
        nrm = np.where(nrm > 0, nrm, 1.0)
        mats /= nrm
        logc += np.log(nrm)
        if d >= n:
            return mats, logc
        mats[:, :, d:] = _matmul_stack(mats[:, :, :-d], mats[:, :, d:])
        logc[d:] = logc[:-d] + logc[d:]
        d *= 2


def scan_loglik(logf: FloatArray, trans: FloatArray, pi: FloatArray, smooth: bool = False,
                starts: Numbers | None = None) -> tuple[FloatArray, ...]:
    """
    Forward filter of a K-state HMM with emission log densities ``logf`` (n, K).

    ``starts`` (n,) bool, forward only: the chain restarts from ``pi`` at
    these samples (segments in one scan: the step into a restart is the
    rank-one matrix ``1 (pi f_t)'``, so each segment's densities are those
    of a scan of its own).

    Returns the one-step predictive log density of each sample and the
    predictive regime probabilities (n, K); with ``smooth`` also the
    smoothed probabilities (n, K) and the expected transition counts (K, K)
    (forward-backward). The linear recursion alpha_t = alpha_{t-1} P diag(f_t)
    runs step by step compiled (:func:`.compiled.kernel`), else as a
    parallel prefix product (vectorised over time) in numpy.
    """
    n, k = logf.shape
    forward, backward = kernel('hmm_forward'), kernel('hmm_backward')
    if forward is not None:
        return _scan_compiled(forward, backward, logf, trans, pi, smooth, starts)
    m = logf.max(axis=1)
    f = np.exp(logf - m[:, None])
    mats = trans[:, :, None] * f.T[None, :, :]         # P[i, j] f_t[j]
    mats[:, :, 0] = np.diag(pi * f[0])
    restart = np.zeros(n, dtype=bool) if starts is None else np.asarray(starts, dtype=bool)
    restart[0] = False
    if restart.any():
        if smooth:
            raise ValueError('scan_loglik: starts is for the forward filter only')
        mats[:, :, restart] = (pi[:, None] * f[restart].T)[None]
    q, logc = _prefix_products(mats)
    alpha = q.sum(axis=0).T                            # (n, k), up to scale
    tot = np.log(alpha.sum(axis=1)) + logc + np.cumsum(m)
    pred_ll = np.diff(np.r_[0.0, tot])
    filt = alpha / alpha.sum(axis=1, keepdims=True)
    pred = np.vstack([pi[None, :], filt[:-1] @ trans])
    pred[restart] = pi
    if not smooth:
        return pred_ll, pred
    # backward: beta_t' = 1' N_{n-1} ... N_{t+1}, N_j = diag(f_j) P'
    beta = np.ones((n, k))
    if n > 1:
        back = f[:0:-1].T[:, None, :] * trans.T[:, :, None]   # (k, k, n-1)
        qb, _ = _prefix_products(back)
        beta[:-1] = qb.sum(axis=0).T[::-1]
    beta /= beta.sum(axis=1, keepdims=True)
    gamma = filt * beta
    gamma /= gamma.sum(axis=1, keepdims=True)
    # xi_t(i, j) ~ filt_t(i) P_ij f_{t+1}(j) beta_{t+1}(j)
    xi = filt[:-1, :, None] * trans[None] * (f[1:] * beta[1:])[:, None, :]
    xi /= xi.sum(axis=(1, 2), keepdims=True)
    return pred_ll, pred, gamma, xi.sum(axis=0)


def _scan_compiled(forward: Callable[..., None], backward: Callable[..., None], logf: FloatArray,
                   trans: FloatArray, pi: FloatArray, smooth: bool,
                   starts: Numbers | None) -> tuple[FloatArray, ...]:
    """Return :func:`scan_loglik`'s outputs from the compiled step-by-step recursions."""
    n, k = logf.shape
    restart = np.zeros(n, dtype=np.bool_) if starts is None else \
        np.array(starts, dtype=np.bool_)
    if smooth and restart[1:].any():
        raise ValueError('scan_loglik: starts is for the forward filter only')
    logf = np.ascontiguousarray(logf, dtype=float)
    trans, pi = np.ascontiguousarray(trans, dtype=float), np.ascontiguousarray(pi, dtype=float)
    pred_ll, pred, filt = np.empty(n), np.empty((n, k)), np.empty((n, k))
    forward(logf, trans, pi, restart, pred_ll, pred, filt)
    if not smooth:
        return pred_ll, pred
    gamma, counts = np.empty((n, k)), np.zeros((k, k))
    backward(logf, trans, filt, gamma, counts)
    return pred_ll, pred, gamma, counts


def law_logpdf(law: Law, r: FloatArray, seg: IntArray) -> tuple[FloatArray, FloatArray]:
    """
    Return per-sample one-step predictive log densities of innovations ``r``.

    ``seg`` gives each sample's segment; regimes restart from their
    stationary distribution at a segment's start. Also returns the predictive
    regime probabilities (n, K).
    """
    k = law.scales.size
    if k == 1:
        return component_logpdf(r, law.cov, law.dof, 1.0), np.ones((len(r), 1))
    pi = stationary_distribution(law.transition)
    logf = np.stack([component_logpdf(r, law.cov, law.dof, s * s)
                     for s in law.scales], axis=1)
    seg = np.asarray(seg)
    order = np.argsort(seg, kind='stable')          # each segment's samples together
    ordered = seg[order]
    starts = np.r_[True, ordered[1:] != ordered[:-1]]
    ll, p = scan_loglik(logf[order], law.transition, pi, starts=starts)
    out, pred = np.empty(len(r)), np.empty((len(r), k))
    out[order], pred[order] = ll, p
    return out, pred


def law_logpdf_given(law: Law, r: FloatArray, pred: FloatArray) -> FloatArray:
    """Return the log densities of ``r`` given the predictive regime probabilities ``pred``."""
    if law.scales.size == 1:
        return component_logpdf(r, law.cov, law.dof, 1.0)
    logf = np.stack([component_logpdf(r, law.cov, law.dof, s * s) for s in law.scales], axis=1)
    with np.errstate(divide='ignore'):
        return special.logsumexp(logf + np.log(pred), axis=1)


def law_from_vector(x: Numbers, coupled: bool, tails: bool, regimes: int) -> Law:
    """Return the :class:`Law` of a parameter vector (``regimes``: 0 or K)."""
    sn, se = math.exp(x[0]), math.exp(x[1])
    i = 2
    rho = 0.0
    if coupled:
        rho = math.tanh(x[i])
        i += 1
    cov = np.array([[sn * sn, rho * sn * se], [rho * sn * se, se * se]])
    dof = math.inf
    if tails:
        dof = 2.0 + max(math.exp(x[i]), 1e-3)      # never 2: the covariance must exist
        i += 1
    scales, trans = np.ones(1), np.ones((1, 1))
    k = regimes
    if k:
        scales = np.cumsum(np.r_[1.0, np.exp(x[i:i + k - 1])])
        i += k - 1
        logits = np.zeros((k, k))
        logits[~np.eye(k, dtype=bool)] = x[i:i + k * (k - 1)]
        trans = special.softmax(logits, axis=1)
    return Law(cov, dof, scales, trans)


def em_regimes(r: FloatArray, seg: IntArray, k: int, coupled: bool, iters: int = 200,
               tol: float = 1e-8) -> Law:
    """Baum-Welch for K Gaussian variance regimes of one shared covariance."""
    cov = np.cov(r.T, bias=True)
    if not coupled:
        cov = np.diag(np.diag(cov))
    q = mahalanobis(r, cov)
    # start: levels at quantiles of the squared radius, sticky transitions
    lv = np.sqrt(np.quantile(q, np.linspace(0.2, 0.9, k)) / 2.0)
    scales = lv / lv[0]
    cov = cov * lv[0] ** 2
    trans = np.full((k, k), 0.05 / (k - 1))
    np.fill_diagonal(trans, 0.95)
    last = -np.inf
    segs = [np.flatnonzero(seg == s) for s in np.unique(seg)]
    for _ in range(iters):
        law = Law(cov, math.inf, scales, trans)
        pi = stationary_distribution(trans)
        logf = np.stack([component_logpdf(r, cov, math.inf, s * s)
                         for s in scales], axis=1)
        gamma = np.empty_like(logf)
        counts = np.zeros((k, k))
        ll = 0.0
        for sel in segs:
            out = scan_loglik(logf[sel], trans, pi, smooth=True)
            ll += out[0].sum()
            gamma[sel] = out[2]
            counts += out[3]
        # M-step (one conditional step each): transitions, scales, covariance
        trans = counts + 1e-9
        trans /= trans.sum(axis=1, keepdims=True)
        q = mahalanobis(r, cov)
        s2 = (gamma * q[:, None]).sum(axis=0) / (2.0 * gamma.sum(axis=0))
        s2 = np.maximum(s2, 1e-12)
        w = gamma @ (1.0 / s2)
        cov = (r * w[:, None]).T @ r / len(r)
        if not coupled:
            cov = np.diag(np.diag(cov))
        order = np.argsort(s2)
        s2, trans = s2[order], trans[np.ix_(order, order)]
        cov = cov * s2[0]
        scales = np.sqrt(s2 / s2[0])
        if ll - last < tol * abs(ll):
            break
        last = ll
    return law


def law_vector(law: Law, coupled: bool, tails: bool, regimes: int) -> FloatArray:
    """Return the parameter vector of ``law`` (inverse of :func:`law_from_vector`)."""
    sd = np.sqrt(np.diag(law.cov))
    x = [math.log(sd[0]), math.log(sd[1])]
    if coupled:
        x.append(math.atanh(np.clip(law.cov[0, 1] / sd.prod(), -0.99, 0.99)))
    if tails:
        x.append(math.log(6.0 - 2.0))
    if regimes:
        x += list(np.log(np.maximum(np.diff(law.scales), 1e-3)))
        lt = np.log(np.maximum(law.transition, 1e-9))
        lt = lt - np.diag(lt)[:, None]
        x += list(lt[~np.eye(regimes, dtype=bool)])
    return np.array(x)


def fit_law(r: FloatArray, seg: IntArray, coupled: bool = False, tails: bool = False,
            regimes: int = 0) -> Law:
    """
    Maximum likelihood of the innovation law on innovations ``r``.

    ``regimes`` is the number of variance regimes (0: none).
    """
    sd = r.std(axis=0)
    if not np.all(sd > 0):
        raise DiagnosisError('the innovations are constant: nothing to fit')
    if not (coupled or tails or regimes):
        return Law(np.diag(np.mean(r * r, axis=0)))
    x0 = [math.log(sd[0]), math.log(sd[1])]
    if coupled:
        x0.append(math.atanh(np.clip(np.atleast_2d(np.corrcoef(r.T))[0, 1], -0.95, 0.95)))
    if tails:
        x0.append(math.log(6.0 - 2.0))
    starts = [np.array(x0)]
    if regimes:
        em = em_regimes(r, seg, regimes, coupled)
        if not tails:
            return em
        starts = [law_vector(em, coupled, tails, regimes)]

    def nll(x: FloatArray) -> float:
        try:
            law = law_from_vector(x, coupled, tails, regimes)
            v = float(-np.sum(law_logpdf(law, r, seg)[0]))
        except (FloatingPointError, ValueError, OverflowError,
                np.linalg.LinAlgError):
            return 1e300
        return v if np.isfinite(v) else 1e300

    fits = []
    for s in starts:
        with np.errstate(all='ignore'):
            fits.append(optimize.minimize(nll, s, method='L-BFGS-B', options={'maxiter': 200}))
    best = min(fits, key=lambda res: res.fun)       # the first of the lowest
    return law_from_vector(best.x, coupled, tails, regimes)
