"""
The ``outliers`` effect in the diagnosis: a filter that sets jumps aside.

The model (:mod:`gps_error_ros.model.outliers`): the observed error is the
AR error plus an offset that is zero on clean steps, starts with
probability ``rate`` on a clean step (``N(0, sigma^2)`` per axis) and holds
until it ends, with probability ``q`` per step. A jump contaminates the AR
prediction of the steps after it, so the mean part predicts from the
*cleaned* past: the residual against the clean prediction is
``r(t) = r_obs(t) + sum_i phi_i o(t - i)``, with ``o`` the offsets of the
last ``p`` steps.

The filter (one pass, causal) carries two states, clean and in a jump,
each with its own estimate of the last ``p`` offsets (an interacting
multiple-model filter): the clean state's past may hold a jump that has
ended, the jump state's the jump's offset ``c``. At each step four
transitions, with the chain's prior weights given the states' weights
``1 - w`` and ``w``:

- clean goes on, ``(1 - w)(1 - rate)``: ``r_c``, the residual from the
  clean state's past, has the innovation law;
- a jump starts, ``(1 - w) rate``: ``r_c ~ N(0, S + sigma^2 I)``;
- the jump ends, ``w (1 - (1 - q) h)``: ``r_j``, the residual from the jump
  state's past, has the innovation law;
- the jump goes on, ``w (1 - q) h``: ``r_j - c ~ N(0, (1 + u) S)`` (the
  offset is known up to ``u``, the innovation of the step it was estimated
  at and its drift since);

with ``S`` the innovations' average covariance and ``h = 1 - exp(-m / (2
HOLD_SD^2))``, ``m`` the tracked offset's squared Mahalanobis length under
the step's innovation covariance: an offset that has drifted back to within
about ``HOLD_SD`` innovation SDs of zero is no longer told apart from a
clean step, so the jump ends there (else going on costs only a wider
density, which the prior to go on outweighs). The simulated offset is held,
``N(0, sigma^2)`` with ``sigma`` several innovation SDs, so the rule seldom
ends a simulated jump early.

Two states rather than one collapsed estimate, because the AR error is
close to a unit root: a jump that goes on is then, step after step, nearly
as likely as the same step having been a large innovation that persists.
A filter that kept only the jump's path after a large step could not go
back, and a jump would follow the AR error for tens of steps; the clean
state keeps the path on which the step was no jump, and takes over when
the jump fails to end.

Each state's new past is the posterior-weighted mean of the pasts of the
transitions into it (the jump's start sets its offset to ``r_c``, its
continuation updates ``c``). Every weight depends on the past only, so the
per-step densities (the four transitions' mixture, the clean ones under
the full innovation law) are a proper one-step predictive likelihood,
scored as any other model's. The merge of each state's transitions into
one past is the approximation.

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

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
import itertools
import math
from typing import Any

import numpy as np
from scipy import special

from gps_error_ros.diagnose.common import LOG2PI
from gps_error_ros.diagnose.compiled import kernel
from gps_error_ros.diagnose.mean import Design
from gps_error_ros.fit.holdout import Part
from gps_error_ros.model.outliers import Outliers
from gps_error_ros.model.state import BoolArray, FloatArray, IntArray, Numbers

#: Start values of the jump parameters: rate, mean length (steps), sigma in innovation SDs.
START = (0.01, 2.0, 6.0)
#: The jump going on: how much its offset may drift per step, in units of S
#: (the reflected path changes as the walker moves), so the filter follows it.
DRIFT = 0.5
#: A jump whose tracked offset is within about this many innovation SDs of
#: zero ends (see the module docstring: ``h``).
HOLD_SD = 1.0
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
    """
    What one pass of the filter gives, per scored sample.

    The transitions' columns, in order: clean goes on, the jump ends, a jump
    starts, the jump goes on.
    """

    r: np.ndarray          # (n, 2) residual given clean: r_c and r_j by their posterior
    r_from: np.ndarray     # (n, 2, 2) residual from the clean state's past, the jump's
    prior: np.ndarray      # (n, 4) the transitions' prior weights
    offset: np.ndarray     # (n, 2) the offset estimated after the step (times inside)
    inside: np.ndarray     # (n,) probability of being in a jump after the step
    post: np.ndarray       # (n, 4) the transitions' posterior weights
    jump_ll: np.ndarray    # (n, 2) log densities: a jump starts, a jump goes on

    def aside(self) -> BoolArray:
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


def broken_segments(seg: IntArray, keep: BoolArray) -> IntArray:
    """Return the segment index of the samples ``keep``, a new segment after each dropped run."""
    start = np.r_[True, seg[1:] != seg[:-1]] | np.r_[False, ~keep[:-1]]
    return np.cumsum(start & keep)[keep] - 1


def _quad(inv: Sequence[Any], x0: Any, x1: Any) -> Any:
    return inv[0] * x0 * x0 + 2 * inv[1] * x0 * x1 + inv[2] * x1 * x1


def _gauss2(x0: Any, x1: Any, inv: Sequence[Any], logdet: Any) -> Any:
    return -LOG2PI - 0.5 * logdet - 0.5 * _quad(inv, x0, x1)


def _inv(c: FloatArray) -> tuple[tuple[float, float, float], float]:
    det = c[0, 0] * c[1, 1] - c[0, 1] ** 2
    return (c[1, 1] / det, -c[0, 1] / det, c[0, 0] / det), math.log(det)


def _inv_plus(c: FloatArray, s2: FloatArray
              ) -> tuple[tuple[FloatArray, FloatArray, FloatArray], FloatArray]:
    """Return the inverse (three entries, each (K,)) and log det of ``c + s2 I`` per ``s2``."""
    a, b, d = c[0, 0] + s2, c[0, 1], c[1, 1] + s2
    det = a * d - b * b
    return (d / det, -b / det, a / det), np.log(det)


class _Tails:
    """The clean innovations' bivariate law per candidate: Gaussian or Student-t (covariance S)."""

    def __init__(self, dofs: Numbers) -> None:
        dof = np.asarray(dofs, dtype=float)
        self.heavy = np.isfinite(dof)
        self.dof = np.where(self.heavy, dof, 4.0)
        self.f = self.dof / (self.dof - 2.0)
        self.const = (special.gammaln(0.5 * (self.dof + 2)) - special.gammaln(0.5 * self.dof)
                      - np.log(self.dof * math.pi) + np.log(self.f))

    def logpdf(self, q: FloatArray, logdet: FloatArray) -> FloatArray:
        """Return the log density of squared Mahalanobis radii ``q`` (K,) under S."""
        gauss = -LOG2PI - 0.5 * logdet - 0.5 * q
        if not self.heavy.any():
            return gauss
        t = self.const - 0.5 * logdet - 0.5 * (self.dof + 2) * np.log1p(q * self.f / self.dof)
        return np.where(self.heavy, t, gauss)


def _t2(x0: Any, x1: Any, inv: Sequence[Any], logdet: Any,
        tail: tuple[float, float, float]) -> Any:
    dof, f, const = tail
    q = inv[0] * x0 * x0 + 2 * inv[1] * x0 * x1 + inv[2] * x1 * x1
    return const - 0.5 * logdet - 0.5 * (dof + 2) * math.log1p(q * f / dof)


def run_filter(r_obs: FloatArray, seg: IntArray, phi: Sequence[FloatArray], cov: FloatArray,
               params: Outliers, scale2: FloatArray | None = None, dof: float = math.inf
               ) -> JumpFilter:
    """
    Return the :class:`JumpFilter` of observed residuals ``r_obs`` (n, 2).

    ``phi``: per axis the AR coefficients; ``cov``: ``S`` (2x2, north/east);
    ``scale2`` (n,): a known factor of ``S`` per sample (a cycle's phase).
    A jump's size does not scale with it. ``dof``: the clean innovations are
    Student-t (heavy tails), so a large innovation is not taken for a jump.
    Samples of a segment are consecutive steps; a segment starts clean, with
    no offset in its past (a jump under way across a gap is taken as a new one).

    Long because the recursion is one loop over the samples, in plain
    floats (a few microseconds a step; :func:`run_filters` steps many
    candidates at once in numpy, at about ten times the cost of one here,
    and is tested to give the same). With the compiled loop
    (:func:`.compiled.kernel`) it is that loop's, for one candidate.
    """
    if kernel('step_candidates') is not None:
        return run_filters(r_obs, seg, phi, cov, [(params, dof)], scale2)[0]
    n = len(r_obs)
    rate, q, s2, kappa = params.rate, params.end_probability, params.sigma_m ** 2, DRIFT
    tails = _Tails([dof])
    tail = (float(tails.dof[0]), float(tails.f[0]), float(tails.const[0])) \
        if tails.heavy[0] else None
    k2 = np.ones(n) if scale2 is None else np.asarray(scale2, dtype=float)
    levels, which = np.unique(k2, return_inverse=True)
    inv = [(_inv(k * cov), _inv(k * cov + s2 * np.eye(2))) for k in levels]
    which = which.tolist()
    coef = [list(map(float, p))[::-1] for p in phi]     # oldest lag first
    lag = max(len(c) for c in coef + [[0.0]])
    coef = [[0.0] * (lag - len(c)) + c for c in coef]
    obs = np.asarray(r_obs, dtype=float).tolist()
    seg = np.asarray(seg).tolist()

    def clean(x: Any, i0: Sequence[Any], d0: Any
              ) -> Any:                   # the innovation law's log density
        return _gauss2(x[0], x[1], i0, d0) if tail is None else _t2(x[0], x[1], i0, d0, tail)
    rows: list[tuple[Any, ...]] = []
    for t in range(n):
        if t == 0 or seg[t] != seg[t - 1]:
            wc, wj, cn, ce, pc = 1.0, 0.0, 0.0, 0.0, 1.0
            past_c, past_j = [[0.0] * lag, [0.0] * lag], [[0.0] * lag, [0.0] * lag]
        rc = [obs[t][a] + sum(map(float.__mul__, coef[a], past_c[a])) for a in (0, 1)]
        rj = [obs[t][a] + sum(map(float.__mul__, coef[a], past_j[a])) for a in (0, 1)]
        (i0, d0), (i1, d1) = inv[which[t]]
        hold = 1.0 - math.exp(-0.5 * _quad(i0, cn, ce) / HOLD_SD ** 2)
        prior = (wc * (1.0 - rate), wj * (1.0 - (1.0 - q) * hold), wc * rate,
                 wj * (1.0 - q) * hold)
        f = 1.0 + pc + kappa            # the jump goes on: offset known up to pc + kappa
        ll = (clean(rc, i0, d0), clean(rj, i0, d0), _gauss2(rc[0], rc[1], i1, d1),
              -LOG2PI - 0.5 * d0 - math.log(f)
              + (_gauss2(rj[0] - cn, rj[1] - ce, i0, 0.0) + LOG2PI) / f)
        top = max(ll)
        a = [p * math.exp(x - top) for p, x in zip(prior, ll)]
        tot = sum(a)
        a = [x / tot for x in a]
        rows.append((rc, rj, prior, a, ll[2:]))
        wc, wj = a[0] + a[1], a[2] + a[3]
        g = (pc + kappa) / f            # Kalman gain of the offset, going on
        gn, ge = cn + g * (rj[0] - cn), ce + g * (rj[1] - ce)
        if wc > 0.0:                    # the clean state: went on or a jump ended
            merged = [[(a[0] * x + a[1] * y) / wc for x, y in zip(past_c[i], past_j[i])]
                      for i in (0, 1)]
        else:
            merged = past_c
        if wj > 0.0:                    # the jump state: started or going on
            cn, ce = (a[2] * rc[0] + a[3] * gn) / wj, (a[2] * rc[1] + a[3] * ge) / wj
            pc = (a[2] + a[3] * (pc + kappa) * (1.0 - g)) / wj
            past_j = [[(a[2] * x + a[3] * y) / wj for x, y in zip(past_c[i], past_j[i])]
                      for i in (0, 1)]
        past_j = [past_j[0][1:] + [cn], past_j[1][1:] + [ce]]
        past_c = [merged[0][1:] + [0.0], merged[1][1:] + [0.0]]
        rows[-1] += (min(1.0, wj), wj * cn, wj * ce)
    return _collect(rows, n)


def _collect(rows: Sequence[tuple[Any, ...]], n: int) -> JumpFilter:
    """Return the :class:`JumpFilter` of :func:`run_filter`'s per-step rows."""
    cols = list(zip(*rows)) if rows else [()] * 8
    rc, rj, prior, post, jll, inside, on, oe = (
        np.asarray(col, dtype=float).reshape((n,) + shape) for col, shape in
        zip(cols, [(2,), (2,), (4,), (4,), (2,), (), (), ()]))
    r_from = np.stack([rc, rj], axis=1)
    return JumpFilter(_given_clean(post, r_from), r_from, prior, np.column_stack([on, oe]),
                      inside, post, jll)


def _given_clean(post: FloatArray, r_from: FloatArray) -> FloatArray:
    """
    Return the residual given clean: ``r_c`` and ``r_j`` weighted by their transitions.

    ``post`` (..., 4), ``r_from`` (..., 2, 2); where neither clean transition
    has any weight (a step surely in a jump), ``r_c``.
    """
    clean = post[..., 0] + post[..., 1]
    some = clean > 1e-300
    both = post[..., :1] * r_from[..., 0, :] + post[..., 1:2] * r_from[..., 1, :]
    return np.where(some[..., None], both / np.where(some, clean, 1.0)[..., None],
                    r_from[..., 0, :])


def run_filters(r_obs: FloatArray, seg: IntArray, phi: Sequence[FloatArray], cov: FloatArray,
                cands: Sequence[tuple[Outliers, float]], scale2: FloatArray | None = None
                ) -> list[JumpFilter]:
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
    s2 = np.array([p.sigma_m ** 2 for p, _ in cands])
    tails = _Tails([d for _, d in cands])
    k2 = np.ones(n) if scale2 is None else np.asarray(scale2, dtype=float)
    levels, which = np.unique(k2, return_inverse=True)
    inv = [(_inv(lev * cov), _inv_plus(lev * cov, s2)) for lev in levels]
    lag = max(1, *(len(p) for p in phi))
    first = np.zeros((lag, 2))              # the coefficient at each ring slot when t % lag is 0
    for a, p in enumerate(phi):
        for i, v in enumerate(np.asarray(p, dtype=float)):   # lag i + 1 sits at (t - i - 1) % lag
            first[(-i - 1) % lag, a] = v
    coef = np.stack([np.roll(first, m, axis=0) for m in range(lag)])   # per t % lag
    r_obs, seg = np.asarray(r_obs, dtype=float), np.asarray(seg)
    out = (np.empty((n, 2, k, 2)), np.empty((n, 4, k)), np.empty((n, 4, k)),
           np.empty((n, 2, k)), np.empty((n, k, 2)))
    step = kernel('step_candidates')
    if step is not None:
        step(r_obs, seg.astype(np.int64), coef,
             np.array([i0 for (i0, _), _ in inv], dtype=float).reshape(-1, 3),
             np.array([d0 for (_, d0), _ in inv], dtype=float),
             np.array([np.stack(i1) for _, (i1, _) in inv], dtype=float).reshape(-1, 3, k),
             np.array([d1 for _, (_, d1) in inv], dtype=float).reshape(-1, k),
             which.astype(np.int64), rate, q, tails.heavy, tails.dof, tails.f, tails.const,
             -0.5 / HOLD_SD ** 2, DRIFT, LOG2PI, *out)
    else:
        _step_candidates(r_obs, seg, coef, inv, which, rate, q, tails, out)
    rf_out, prior_out, post_out, ll_out, off = out
    rf_out, prior_out = rf_out.transpose(0, 2, 1, 3), prior_out.transpose(0, 2, 1)
    post_out, ll_out = post_out.transpose(0, 2, 1), ll_out.transpose(0, 2, 1)
    inside = np.minimum(1.0, post_out[:, :, 2] + post_out[:, :, 3])
    r = _given_clean(post_out, rf_out)
    return [JumpFilter(r[:, j], rf_out[:, j], prior_out[:, j], off[:, j], inside[:, j],
                       post_out[:, j], ll_out[:, j]) for j in range(k)]


def _step_candidates(r_obs: FloatArray, seg: IntArray, coef: FloatArray, inv: Any, which: IntArray,
                     rate: FloatArray, q: FloatArray, tails: _Tails, out: Any) -> None:
    """
    Step the candidates through the filter in numpy; write :func:`run_filters`' ``out``.

    The loop :mod:`.kernels` compiles (this runs when numba is not installed).

    Long because the recursion is one loop over the samples.
    """
    n, k, lag = len(r_obs), len(rate), coef.shape[1]
    rf_out, prior_out, post_out, ll_out, off = out
    for t in range(n):
        if t == 0 or seg[t] != seg[t - 1]:
            wc, wj, c, pc = np.ones(k), np.zeros(k), np.zeros((k, 2)), np.ones(k)
            past = np.zeros((2, k, lag, 2))     # the states' last offsets: clean, jump (a ring)
        slot = t % lag
        rs = r_obs[t] + (past * coef[slot]).sum(axis=2)     # (2, k, 2): r_c, r_j
        (i0, d0), (i1, d1) = inv[which[t]]
        y = np.concatenate([rs, (rs[1] - c)[None], c[None]])  # r_c, r_j, r_j - c, c
        q0 = _quad(i0, y[..., 0], y[..., 1])
        hold = 1.0 - np.exp(q0[3] * (-0.5 / HOLD_SD ** 2))
        goon = wj * (1.0 - q) * hold
        prior = np.array([wc * (1.0 - rate), wj - goon, wc * rate, goon])
        f = 1.0 + pc + DRIFT            # the jump goes on: offset known up to pc + DRIFT
        ll = np.empty((4, k))
        ll[:2] = tails.logpdf(q0[:2], d0)
        ll[2] = -LOG2PI - 0.5 * d1 - 0.5 * _quad(i1, y[0, :, 0], y[0, :, 1])
        ll[3] = -LOG2PI - 0.5 * d0 - np.log(f) - 0.5 * q0[2] / f
        x = np.log(np.maximum(prior, 1e-300)) + ll
        a = np.exp(x - x.max(axis=0))
        a /= a.sum(axis=0)
        rf_out[t], prior_out[t], post_out[t], ll_out[t] = rs, prior, a, ll[2:]
        wc, wj = a[0] + a[1], a[2] + a[3]
        g = (pc + DRIFT) / f            # Kalman gain of the offset, going on
        lost_c, lost_j = wc <= 0.0, wj <= 0.0     # a state with no weight keeps its past
        w = a / np.array([wc + lost_c, wc + lost_c, wj + lost_j, wj + lost_j])
        new_c = (w[:2, :, None, None] * past).sum(axis=0) + lost_c[:, None, None] * past[0]
        new_j = (w[2:, :, None, None] * past).sum(axis=0) + lost_j[:, None, None] * past[1]
        c = w[2, :, None] * y[0] + w[3, :, None] * (c + g[:, None] * y[2]) + lost_j[:, None] * c
        pc = w[2] + w[3] * (pc + DRIFT) * (1.0 - g) + lost_j * pc
        new_c[:, slot], new_j[:, slot] = 0.0, c     # the oldest slot takes this step's offset
        past[0], past[1] = new_c, new_j
        off[t] = wj[:, None] * c


def mixture_logpdf(jf: JumpFilter, clean_ll: FloatArray) -> FloatArray:
    """
    Return per-sample log densities: the four transitions, weighted by the prior.

    ``clean_ll`` (n, 2): the innovation law's log densities of the residuals
    from the clean state's past and from the jump's (``jf.r_from``).
    """
    with np.errstate(divide='ignore'):
        parts = np.log(jf.prior) + np.column_stack([clean_ll, jf.jump_ll])
    top = parts.max(axis=1)
    return top + np.log(np.exp(parts - top[:, None]).sum(axis=1))


def shifted_offsets(offset: FloatArray, seg: IntArray, lag: int) -> FloatArray:
    """Return the offset ``lag`` samples back within the segment (0 before its start)."""
    out = np.zeros_like(offset)
    if lag < len(offset):
        same = seg[lag:] == seg[:-lag]
        out[lag:][same] = offset[:-lag][same]
    return out


def cleaned_design(d: Design, offset: FloatArray) -> Design:
    """Return design ``d`` with the offsets taken out of its samples and their lags."""
    lags = [np.stack([x[:, i] - shifted_offsets(offset, d.seg, i + 1)[:, a]
                      for i in range(x.shape[1])], axis=1) if x.shape[1] else x
            for a, x in enumerate(d.lags)]
    return Design(d.y - offset, lags, d.seg, d.heading, d.steps)


def cleaned_part(part: Part, offset: FloatArray, m0: int) -> Part:
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


def design_subset(d: Design, keep: BoolArray) -> Design:
    """Return the samples ``keep`` (boolean) of design ``d``."""
    return Design(d.y[keep], [x[keep] for x in d.lags], d.seg[keep],
                  None if d.heading is None else d.heading[keep],
                  None if d.steps is None else d.steps[keep])


def _unpack(x: Numbers) -> tuple[Outliers, float]:
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


def _pack(params: Outliers, dof: float = math.inf) -> FloatArray:
    lo, hi = RATE_BOUNDS
    frac = (params.rate - lo) / (hi - lo)
    x = [math.log(frac / (1 - frac)), math.log(max(params.mean_steps - 1.0, 1e-3)),
         math.log(params.sigma_m)]
    return np.array(x + ([math.log(dof - 2.0)] if math.isfinite(dof) else []))


def search_params(loglik_many: Callable[[list[tuple[Outliers, float]]], Numbers], sd: Numbers,
                  start: Outliers | None = None, start_dof: float = math.inf,
                  tails: bool = False, wide: bool = True) -> tuple[Outliers, float]:
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
        if best is None:
            raise ValueError('search_params: no candidate has a finite likelihood')
        pts = [best + step * np.array(o) for o in itertools.product((-1, 0, 1), repeat=len(best))
               if any(o)]
        step = 0.5 * step
    return _unpack(best)


def moment_start(jf: JumpFilter, cov: FloatArray) -> Outliers | None:
    """Return start values from one pass: the posterior starts, lengths and sizes (of r_c)."""
    w = jf.inside
    starts = np.maximum(w - np.r_[0.0, w[:-1]], 0.0)
    n_starts = float(starts.sum())
    if n_starts < 1.0:
        return None
    rate = n_starts / max(float(np.sum(1.0 - w)), 1.0)
    steps = max(1.0, float(w.sum()) / n_starts)
    size2 = float(np.sum(starts * np.sum(jf.r_from[:, 0] ** 2, axis=1)) / (2.0 * n_starts))
    sigma = math.sqrt(max(size2 - 0.5 * float(np.trace(cov)), float(np.trace(cov))))
    rate = min(max(rate, RATE_BOUNDS[0] * 2), RATE_BOUNDS[1] / 2)
    return Outliers(rate, min(steps, MEAN_STEPS_BOUNDS[1] / 2), sigma)
