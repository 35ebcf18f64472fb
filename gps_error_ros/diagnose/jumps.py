"""
The ``outliers`` effect in the diagnosis: a filter that sets jumps aside.

The model (:mod:`gps_error_ros.model.outliers`): the observed error is the
AR error plus an offset that is zero on clean steps, starts with
probability ``rate`` on a clean step (``N(0, sigma^2)`` per axis) and holds
until it ends, with probability ``q`` per step. A jump contaminates the AR
prediction of the steps after it, so the mean part predicts from the
*cleaned* past: the residual against the clean prediction is
``r(t) = r_obs(t) + sum_i phi_i o(t - i)``, with ``o`` the filter's
estimate of the offset at each earlier step.

The filter (one pass, causal): at each step three hypotheses, with the
prior weights of the two-state chain given the last step's probability
``w`` of being in a jump:

- clean, ``1 - (1 - w) rate - w (1 - q)``: ``r`` has the innovation law;
- a jump starts, ``(1 - w) rate``: ``r ~ N(0, S + sigma^2 I)``;
- the jump goes on, ``w (1 - q)``: ``r - o(t - 1) ~ N(0, 2 S)`` (the offset
  is known up to the innovation of the step it was estimated at);

with ``S`` the innovations' average covariance. The posterior weights give
the new ``w`` and the offset ``o(t)`` (the jump's start sets it to ``r``,
its continuation keeps it). Every weight depends on the past only, so the
per-step densities (a mixture of the three, the clean one being the full
innovation law) are a proper one-step predictive likelihood, scored as any
other model's. The collapse to one offset estimate per step (rather than a
mixture of paths) is the approximation.

Fit: the mean part by least squares on the series with the jumps taken out,
the law on the residuals of the clean steps, then ``rate``, ``q`` and
``sigma`` (with heavy tails also the law's dof: a large innovation that
persists and a short jump explain the same outlier, so they are weighed
together) by maximum likelihood over a grid refined around its best
(:func:`search_params`; the candidates are stepped through the filter side
by side, :func:`run_filters`), twice: over the whole range, then around the
best after the mean part and the law are refitted with those jumps aside.
A local search from one start stays in whichever explanation it started in.
"""

from dataclasses import dataclass, replace
import itertools
import math

import numpy as np
from scipy import special

from gps_error_ros.diagnose.common import LOG2PI
from gps_error_ros.diagnose.mean import Design
from gps_error_ros.model.outliers import Outliers

#: Start values of the jump parameters: rate, mean length (steps), sigma in innovation SDs.
START = (0.01, 2.0, 6.0)
#: The jump going on: how much its offset may drift per step, in units of S
#: (the reflected path changes as the walker moves), so the filter follows it.
DRIFT = 0.5
#: The probability of a jump at or just before a step that sets it aside from the
#: law's tests: more likely in a jump than not (as the law's fit sets steps aside).
ASIDE = 0.5
#: Bounds of the fitted parameters.
RATE_BOUNDS = (1e-5, 0.3)
MEAN_STEPS_BOUNDS = (1.0, 60.0)
#: The wide search's grid of jump sizes (innovation SDs) and of the tails' dof.
GRID_SIZES = (3.0, 6.0, 12.0, 24.0)
GRID_DOFS = (3.0, 5.0, 10.0, 30.0)
#: Half the wide grid's spacing in the search's coordinates (the first refinement's step).
GRID_STEP = np.array([0.5, 0.45, 0.35, 0.55])
#: Rounds of the search's refinement, each around the best so far at half the spacing.
SEARCH_ROUNDS = 3


@dataclass
class JumpFilter:
    """What one pass of the filter gives, per scored sample."""

    r: np.ndarray          # (n, 2) residual against the clean prediction
    prior: np.ndarray      # (n, 3) weights: clean, a jump starts, a jump goes on
    prev: np.ndarray       # (n, 2) the offset carried into the step, given a jump
    offset: np.ndarray     # (n, 2) the offset estimated after the step (times inside)
    inside: np.ndarray     # (n,) probability of being in a jump after the step
    spread: np.ndarray     # (n,) the jump going on: its density's covariance / S
    post: np.ndarray       # (n, 3) posterior weights of the three hypotheses
    jump_ll: np.ndarray    # (n, 2) log densities: a jump starts, a jump goes on

    def aside(self):
        """
        Return, per step, whether the law's tests set it aside.

        A step is set aside when it is in a jump (a start or a continuation)
        with probability ``ASIDE`` or more, or when the step before was: the
        residual at which a jump ends carries the error of the tracked offset
        through the AR coefficients, which a wandering jump makes larger than
        the filter's own uncertainty. The tests drop these steps and break
        their segments there (:func:`broken_segments`) rather than see them
        as zeros, which would pass for a burst of low variance.
        """
        before = np.r_[0.0, self.inside[:-1]]
        return (self.inside >= ASIDE) | (before >= ASIDE)


def broken_segments(seg, keep):
    """Return the segment index of the samples ``keep``, a new segment after each dropped run."""
    start = np.r_[True, seg[1:] != seg[:-1]] | np.r_[False, ~keep[:-1]]
    return np.cumsum(start & keep)[keep] - 1


def _quad(inv, x0, x1):
    return inv[0] * x0 * x0 + 2 * inv[1] * x0 * x1 + inv[2] * x1 * x1


def _gauss2(x0, x1, inv, logdet):
    return -LOG2PI - 0.5 * logdet - 0.5 * _quad(inv, x0, x1)


def _inv(c):
    det = c[0, 0] * c[1, 1] - c[0, 1] ** 2
    return (c[1, 1] / det, -c[0, 1] / det, c[0, 0] / det), math.log(det)


def _inv_plus(c, s2):
    """Return the inverse (three entries, each (K,)) and log det of ``c + s2 I`` per ``s2``."""
    a, b, d = c[0, 0] + s2, c[0, 1], c[1, 1] + s2
    det = a * d - b * b
    return (d / det, -b / det, a / det), np.log(det)


class _Tails:
    """The clean innovations' bivariate law per candidate: Gaussian or Student-t (covariance S)."""

    def __init__(self, dofs):
        dof = np.asarray(dofs, dtype=float)
        self.heavy = np.isfinite(dof)
        self.dof = np.where(self.heavy, dof, 4.0)
        self.f = self.dof / (self.dof - 2.0)
        self.const = (special.gammaln(0.5 * (self.dof + 2)) - special.gammaln(0.5 * self.dof)
                      - np.log(self.dof * math.pi) + np.log(self.f))

    def logpdf(self, q, logdet):
        """Return the log density of squared Mahalanobis radii ``q`` (K,) under S."""
        gauss = -LOG2PI - 0.5 * logdet - 0.5 * q
        if not self.heavy.any():
            return gauss
        t = self.const - 0.5 * logdet - 0.5 * (self.dof + 2) * np.log1p(q * self.f / self.dof)
        return np.where(self.heavy, t, gauss)


def _t2(x0, x1, inv, logdet, tail):
    dof, f, const = tail
    q = inv[0] * x0 * x0 + 2 * inv[1] * x0 * x1 + inv[2] * x1 * x1
    return const - 0.5 * logdet - 0.5 * (dof + 2) * math.log1p(q * f / dof)


def run_filter(r_obs, seg, phi, cov, params, scale2=None, dof=math.inf):
    """
    Return the :class:`JumpFilter` of observed residuals ``r_obs`` (n, 2).

    ``phi``: per axis the AR coefficients; ``cov``: ``S`` (2x2, north/east);
    ``scale2`` (n,): a known factor of ``S`` per sample (a cycle's phase).
    A jump's size does not scale with it. ``dof``: the clean innovations are
    Student-t (heavy tails), so a large innovation is not taken for a jump.
    Samples of a segment are consecutive steps; a segment starts with the
    jump probability at its stationary share and no offset in its past.

    Long because the recursion is one loop over the samples, in plain
    floats (a few microseconds a step; :func:`run_filters` steps many
    candidates at once in numpy, at about ten times the cost of one here,
    and is tested to give the same).
    """
    n = len(r_obs)
    rate, q, s2, kappa = params.rate, params.end_probability, params.sigma_m ** 2, DRIFT
    tails = _Tails([dof])
    tail = (float(tails.dof[0]), float(tails.f[0]), float(tails.const[0])) \
        if tails.heavy[0] else None
    k2 = np.ones(n) if scale2 is None else np.asarray(scale2, dtype=float)
    levels, which = np.unique(k2, return_inverse=True)
    inv = [(_inv(k * cov), _inv(k * cov + s2 * np.eye(2))) for k in levels]
    which = which.tolist()
    phn, phe = (list(map(float, p)) for p in phi)
    rn, re = (np.asarray(r_obs, dtype=float)[:, a].tolist() for a in range(2))
    seg = np.asarray(seg).tolist()
    on_hist, oe_hist = [0.0] * n, [0.0] * n
    prior, prev, spread, inside = [None] * n, [None] * n, [0.0] * n, [0.0] * n
    post, jump_ll = [None] * n, [None] * n
    w, cn, ce, pc, start = params.share, 0.0, 0.0, 1.0, 0
    for t in range(n):
        if t == 0 or seg[t] != seg[t - 1]:
            w, cn, ce, pc, start = params.share, 0.0, 0.0, 1.0, t
        xn, xe = rn[t], re[t]
        for i in range(min(len(phn), t - start)):
            xn += phn[i] * on_hist[t - 1 - i]
        for i in range(min(len(phe), t - start)):
            xe += phe[i] * oe_hist[t - 1 - i]
        rn[t], re[t] = xn, xe
        p1, p2 = (1.0 - w) * rate, w * (1.0 - q)
        p0 = (1.0 - w) * (1.0 - rate) + w * q
        f = 1.0 + pc + kappa            # the jump goes on: offset known up to pc + kappa
        prior[t], prev[t], spread[t] = (p0, p1, p2), (cn, ce), f
        (i0, d0), (i1, d1) = inv[which[t]]
        l0 = _gauss2(xn, xe, i0, d0) if tail is None else _t2(xn, xe, i0, d0, tail)
        l1 = _gauss2(xn, xe, i1, d1)
        l2 = -LOG2PI - 0.5 * d0 - math.log(f) + \
            (_gauss2(xn - cn, xe - ce, i0, 0.0) + LOG2PI) / f
        top = max(l0, l1, l2)
        a0 = p0 * math.exp(l0 - top)
        a1 = p1 * math.exp(l1 - top)
        a2 = p2 * math.exp(l2 - top)
        tot = a0 + a1 + a2
        a0, a1, a2 = a0 / tot, a1 / tot, a2 / tot
        post[t], jump_ll[t] = (a0, a1, a2), (l1, l2)
        w = min(1.0, a1 + a2)
        g = (pc + kappa) / f            # Kalman gain of the offset, going on
        gn, ge = cn + g * (xn - cn), ce + g * (xe - ce)
        if w > 0.0:                     # the offset given a jump: started or going on
            cn, ce = (a1 * xn + a2 * gn) / w, (a1 * xe + a2 * ge) / w
            pc = (a1 * 1.0 + a2 * (pc + kappa) * (1.0 - g)) / w
        on_hist[t], oe_hist[t] = w * cn, w * ce
        inside[t] = w
    r = np.stack([np.asarray(rn), np.asarray(re)], axis=1).reshape(n, 2)
    off = np.stack([np.asarray(on_hist), np.asarray(oe_hist)], axis=1).reshape(n, 2)
    prior = np.asarray(prior, dtype=float).reshape(n, 3)
    prev = np.asarray(prev, dtype=float).reshape(n, 2)
    inside = np.asarray(inside)
    return JumpFilter(r, prior, prev, off, inside, np.asarray(spread),
                      np.asarray(post, dtype=float).reshape(n, 3),
                      np.asarray(jump_ll, dtype=float).reshape(n, 2))


def run_filters(r_obs, seg, phi, cov, cands, scale2=None):
    """
    Return one :class:`JumpFilter` per candidate ``(Outliers, dof)``, in one pass.

    As :func:`run_filter`, the candidates stepped side by side (numpy over
    the candidates, one loop over the samples), so that a grid of
    parameters costs little more than one of them.

    Long because the recursion is one loop over the samples.
    """
    n, k = len(r_obs), len(cands)
    rate = np.array([p.rate for p, _ in cands])
    q = np.array([p.end_probability for p, _ in cands])
    share = np.array([p.share for p, _ in cands])
    s2 = np.array([p.sigma_m ** 2 for p, _ in cands])
    tails = _Tails([d for _, d in cands])
    k2 = np.ones(n) if scale2 is None else np.asarray(scale2, dtype=float)
    levels, which = np.unique(k2, return_inverse=True)
    inv = [(_inv(lev * cov), _inv_plus(lev * cov, s2)) for lev in levels]
    phn, phe = (np.asarray(p, dtype=float)[::-1] for p in phi)   # oldest lag first
    r_obs = np.asarray(r_obs, dtype=float)
    seg = np.asarray(seg)
    x_out, prev_out = np.empty((n, k, 2)), np.empty((n, k, 2))
    prior_out, post_out = np.empty((n, k, 3)), np.empty((n, k, 3))
    ll_out = np.empty((n, k, 2))
    spread_out, off = np.empty((n, k)), np.zeros((n, k, 2))
    w = cn = ce = pc = None
    start = 0
    for t in range(n):
        if t == 0 or seg[t] != seg[t - 1]:
            w, cn, ce, pc, start = share.copy(), np.zeros(k), np.zeros(k), np.ones(k), t
        mn, me = min(len(phn), t - start), min(len(phe), t - start)
        xn = r_obs[t, 0] + (phn[len(phn) - mn:] @ off[t - mn:t, :, 0] if mn else 0.0)
        xe = r_obs[t, 1] + (phe[len(phe) - me:] @ off[t - me:t, :, 1] if me else 0.0)
        p1, p2 = (1.0 - w) * rate, w * (1.0 - q)
        p0 = 1.0 - p1 - p2
        f = 1.0 + pc + DRIFT            # the jump goes on: offset known up to pc + DRIFT
        (i0, d0), (i1, d1) = inv[which[t]]
        l0 = tails.logpdf(_quad(i0, xn, xe), d0)
        l1 = -LOG2PI - 0.5 * d1 - 0.5 * _quad(i1, xn, xe)
        l2 = -LOG2PI - 0.5 * d0 - np.log(f) - 0.5 * _quad(i0, xn - cn, xe - ce) / f
        top = np.maximum(np.maximum(l0, l1), l2)
        a0, a1, a2 = p0 * np.exp(l0 - top), p1 * np.exp(l1 - top), p2 * np.exp(l2 - top)
        tot = a0 + a1 + a2
        a0, a1, a2 = a0 / tot, a1 / tot, a2 / tot
        x_out[t, :, 0], x_out[t, :, 1] = xn, xe
        prev_out[t, :, 0], prev_out[t, :, 1] = cn, ce
        prior_out[t, :, 0], prior_out[t, :, 1], prior_out[t, :, 2] = p0, p1, p2
        post_out[t, :, 0], post_out[t, :, 1], post_out[t, :, 2] = a0, a1, a2
        spread_out[t], ll_out[t, :, 0], ll_out[t, :, 1] = f, l1, l2
        w = np.minimum(1.0, a1 + a2)
        g = (pc + DRIFT) / f            # Kalman gain of the offset, going on
        ws = np.where(w > 0.0, w, 1.0)  # the offset given a jump: started or going on
        kept = w > 0.0
        cn = np.where(kept, (a1 * xn + a2 * (cn + g * (xn - cn))) / ws, cn)
        ce = np.where(kept, (a1 * xe + a2 * (ce + g * (xe - ce))) / ws, ce)
        pc = np.where(kept, (a1 + a2 * (pc + DRIFT) * (1.0 - g)) / ws, pc)
        off[t, :, 0], off[t, :, 1] = w * cn, w * ce
    inside = post_out[:, :, 1] + post_out[:, :, 2]
    return [JumpFilter(x_out[:, j], prior_out[:, j], prev_out[:, j], off[:, j],
                       np.minimum(1.0, inside[:, j]), spread_out[:, j], post_out[:, j],
                       ll_out[:, j]) for j in range(k)]


def mixture_logpdf(jf, clean_ll):
    """Return per-sample log densities: the three hypotheses, weighted by the prior."""
    with np.errstate(divide='ignore'):
        parts = np.log(jf.prior) + np.column_stack([clean_ll, jf.jump_ll])
    top = parts.max(axis=1)
    return top + np.log(np.exp(parts - top[:, None]).sum(axis=1))


def shifted_offsets(offset, seg, lag):
    """Return the offset ``lag`` samples back within the segment (0 before its start)."""
    out = np.zeros_like(offset)
    if lag < len(offset):
        same = seg[lag:] == seg[:-lag]
        out[lag:][same] = offset[:-lag][same]
    return out


def cleaned_design(d, offset):
    """Return design ``d`` with the offsets taken out of its samples and their lags."""
    lags = [np.stack([x[:, i] - shifted_offsets(offset, d.seg, i + 1)[:, a]
                      for i in range(x.shape[1])], axis=1) if x.shape[1] else x
            for a, x in enumerate(d.lags)]
    return Design(d.y - offset, lags, d.seg, d.heading, d.steps)


def cleaned_part(part, offset, m0):
    """
    Return ``part`` with the offsets taken out of its errors.

    ``offset`` (n, 2) is per sample of the part's design with ``m0`` samples
    per segment conditioned on (those keep their error).
    """
    errs, k = [], 0
    for e in part.err:
        m = max(0, len(e) - m0)
        e = e.copy()
        e[m0:] -= offset[k:k + m]
        errs.append(e)
        k += m
    if k != len(offset):
        raise ValueError(f'{len(offset)} offsets for a design of {k} samples')
    return replace(part, err=errs)


def design_subset(d, keep):
    """Return the samples ``keep`` (boolean) of design ``d``."""
    return Design(d.y[keep], [x[keep] for x in d.lags], d.seg[keep],
                  None if d.heading is None else d.heading[keep],
                  None if d.steps is None else d.steps[keep])


def _unpack(x):
    """
    Return ``(Outliers, dof)`` of search coordinates.

    The coordinates: logit of the rate in its bounds, log(mean length - 1),
    log sigma and, with tails, log(dof - 2).
    """
    lo, hi = RATE_BOUNDS
    rate = lo + (hi - lo) / (1.0 + math.exp(-x[0]))
    steps = min(MEAN_STEPS_BOUNDS[1], 1.0 + math.exp(x[1]))
    dof = 2.0 + math.exp(x[3]) if len(x) > 3 else math.inf
    return Outliers(rate, steps, math.exp(x[2])), dof


def _pack(params, dof=math.inf):
    lo, hi = RATE_BOUNDS
    frac = (params.rate - lo) / (hi - lo)
    x = [math.log(frac / (1 - frac)), math.log(max(params.mean_steps - 1.0, 1e-3)),
         math.log(params.sigma_m)]
    return np.array(x + ([math.log(dof - 2.0)] if math.isfinite(dof) else []))


def search_params(loglik_many, sd, start=None, start_dof=math.inf, tails=False, wide=True):
    """
    Return ``(Outliers, dof)`` maximising the likelihood, by a grid refined around its best.

    ``loglik_many(cands)``: the training log likelihood of each candidate
    ``(Outliers, dof)``; ``sd``: the innovations' SD per axis (sizes are
    searched in its units); ``tails``: the clean innovations are Student-t
    and their dof is searched with the jumps (a persisting large innovation
    and a short jump explain the same outlier: they are weighed together,
    or the first fitted takes it). ``wide``: start from a grid over the whole
    range (rates 0.1-5 %, mean lengths 1.5-12 steps, sizes 3-24 SDs, dof
    3-30), which a local search from a poor start would not leave; else
    from ``start``. Each round halves the grid's spacing.
    """
    dof0 = start_dof if tails else math.inf
    if wide:
        axes = [np.geomspace(0.001, 0.05, 5), (1.5, 3.0, 6.0, 12.0), sd * np.array(GRID_SIZES)]
        axes += [GRID_DOFS] if tails else []
        pts = [_pack(Outliers(*c[:3]), c[3] if tails else math.inf)
               for c in itertools.product(*axes)]
        step = GRID_STEP[:len(axes)].copy()
    else:
        step = 0.5 * GRID_STEP[:3 + bool(tails)]
        pts = []
    if start is not None:
        pts.append(_pack(start, dof0))
    best, best_ll = None, -math.inf
    for _ in range(SEARCH_ROUNDS + 1):
        lls = np.asarray(loglik_many([_unpack(x) for x in pts]), dtype=float)
        lls = np.where(np.isfinite(lls), lls, -np.inf)
        if lls.size and lls.max() > best_ll:
            best, best_ll = pts[int(np.argmax(lls))], float(lls.max())
        pts = [best + step * np.array(o) for o in itertools.product((-1, 0, 1), repeat=len(best))
               if any(o)]
        step = 0.5 * step
    return _unpack(best)


def moment_start(jf, cov):
    """Return start values from one pass: the posterior starts, lengths and sizes."""
    w = jf.inside
    starts = np.maximum(w - np.r_[0.0, w[:-1]], 0.0)
    n_starts = float(starts.sum())
    if n_starts < 1.0:
        return None
    rate = n_starts / max(float(np.sum(1.0 - w)), 1.0)
    steps = max(1.0, float(w.sum()) / n_starts)
    size2 = float(np.sum(starts * np.sum(jf.r ** 2, axis=1)) / (2.0 * n_starts))
    sigma = math.sqrt(max(size2 - 0.5 * float(np.trace(cov)), float(np.trace(cov))))
    rate = min(max(rate, RATE_BOUNDS[0] * 2), RATE_BOUNDS[1] / 2)
    return Outliers(rate, min(steps, MEAN_STEPS_BOUNDS[1] / 2), sigma)
