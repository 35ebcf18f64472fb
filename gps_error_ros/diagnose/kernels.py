"""
The diagnosis's recursions compiled with numba (the optional extra ``fast``).

:func:`step_candidates` is the loop of :func:`.jumps.run_filters` over the
samples, written out per candidate in plain floats; :func:`hmm_forward` and
:func:`hmm_backward` are the variance regimes' forward filter and backward
pass of :func:`.laws.scan_loglik`, step by step. numba compiles them to
machine code on first use and caches it beside this file. Each agrees with
its numpy form to rounding (tested). Reach them only through
:func:`.compiled.kernel`, which returns None when numba is not installed:
the numpy forms then run.
"""

import math

import numba
import numpy as np

from gps_error_ros.model.state import BoolArray, FloatArray, IntArray


@numba.njit(cache=True)
def _quad(i0: float, i1: float, i2: float, x0: float, x1: float) -> float:
    return i0 * x0 * x0 + 2 * i1 * x0 * x1 + i2 * x1 * x1


@numba.njit(cache=True)
def _clean_logpdf(q: float, logdet: float, heavy: bool, dof: float, f: float, const: float,
                  log2pi: float) -> float:
    if heavy:
        return const - 0.5 * logdet - 0.5 * (dof + 2) * math.log1p(q * f / dof)
    return -log2pi - 0.5 * logdet - 0.5 * q


@numba.njit(cache=True)
def step_candidates(r_obs: FloatArray, seg: IntArray, coef: FloatArray, inv0: FloatArray,
                    logdet0: FloatArray, inv1: FloatArray, logdet1: FloatArray,
                    which: IntArray, rate: FloatArray, end_q: FloatArray, heavy: BoolArray,
                    dof: FloatArray, f_t: FloatArray, const: FloatArray, hold_scale: float,
                    drift: float, log2pi: float, rf_out: FloatArray, prior_out: FloatArray,
                    post_out: FloatArray, ll_out: FloatArray, off: FloatArray) -> None:
    """
    Step ``k`` candidates through the filter; write the numpy loop's outputs in place.

    Shapes (``n`` samples, ``k`` candidates, ``lag`` AR lags, ``L`` scale
    levels): ``r_obs`` (n, 2); ``seg`` (n,); ``coef`` (lag, lag, 2): the
    coefficient at each ring slot per ``t % lag``; ``inv0`` (L, 3),
    ``logdet0`` (L,): the clean law's inverse and log det per level;
    ``inv1`` (L, 3, k), ``logdet1`` (L, k): those of a jump's start per
    candidate; ``which`` (n,): each sample's level; ``rate``, ``end_q``,
    ``heavy``, ``dof``, ``f_t``, ``const`` (k,): the candidates' jump
    parameters and tails; ``hold_scale``: ``-0.5 / HOLD_SD ** 2``. Outputs:
    ``rf_out`` (n, 2, k, 2), ``prior_out`` and ``post_out`` (n, 4, k),
    ``ll_out`` (n, 2, k), ``off`` (n, k, 2).

    Long because it is the numpy loop written out term by term, which
    numba compiles only as one function.
    """
    n = r_obs.shape[0]
    k = rate.shape[0]
    lag = coef.shape[1]
    past = np.zeros((2, k, lag, 2))
    new_c = np.zeros((lag, 2))
    new_j = np.zeros((lag, 2))
    wc = np.ones(k)
    wj = np.zeros(k)
    c = np.zeros((k, 2))
    pc = np.ones(k)
    y = np.zeros((4, 2))
    prior = np.zeros(4)
    ll = np.zeros(4)
    a = np.zeros(4)
    for t in range(n):
        if t == 0 or seg[t] != seg[t - 1]:
            past[:] = 0.0
            wc[:] = 1.0
            wj[:] = 0.0
            c[:] = 0.0
            pc[:] = 1.0
        slot = t % lag
        lev = which[t]
        i00, i01, i02 = inv0[lev, 0], inv0[lev, 1], inv0[lev, 2]
        d0 = logdet0[lev]
        for j in range(k):
            for s in range(2):
                for ax in range(2):
                    acc = past[s, j, 0, ax] * coef[slot, 0, ax]
                    for i in range(1, lag):
                        acc += past[s, j, i, ax] * coef[slot, i, ax]
                    y[s, ax] = r_obs[t, ax] + acc
            for ax in range(2):
                y[2, ax] = y[1, ax] - c[j, ax]
                y[3, ax] = c[j, ax]
            q0 = _quad(i00, i01, i02, y[0, 0], y[0, 1])
            q1 = _quad(i00, i01, i02, y[1, 0], y[1, 1])
            q2 = _quad(i00, i01, i02, y[2, 0], y[2, 1])
            q3 = _quad(i00, i01, i02, y[3, 0], y[3, 1])
            hold = 1.0 - math.exp(q3 * hold_scale)
            goon = wj[j] * (1.0 - end_q[j]) * hold
            prior[0] = wc[j] * (1.0 - rate[j])
            prior[1] = wj[j] - goon
            prior[2] = wc[j] * rate[j]
            prior[3] = goon
            f = 1.0 + pc[j] + drift
            ll[0] = _clean_logpdf(q0, d0, heavy[j], dof[j], f_t[j], const[j], log2pi)
            ll[1] = _clean_logpdf(q1, d0, heavy[j], dof[j], f_t[j], const[j], log2pi)
            ll[2] = -log2pi - 0.5 * logdet1[lev, j] - 0.5 * _quad(
                inv1[lev, 0, j], inv1[lev, 1, j], inv1[lev, 2, j], y[0, 0], y[0, 1])
            ll[3] = -log2pi - 0.5 * d0 - math.log(f) - 0.5 * q2 / f
            top = -math.inf
            for m in range(4):
                a[m] = math.log(max(prior[m], 1e-300)) + ll[m]
                top = max(top, a[m])
            tot = 0.0
            for m in range(4):
                a[m] = math.exp(a[m] - top)
                tot += a[m]
            for m in range(4):
                a[m] /= tot
                prior_out[t, m, j] = prior[m]
                post_out[t, m, j] = a[m]
            for s in range(2):
                ll_out[t, s, j] = ll[2 + s]
                for ax in range(2):
                    rf_out[t, s, j, ax] = y[s, ax]
            wcj, wjj = a[0] + a[1], a[2] + a[3]
            g = (pc[j] + drift) / f
            lost_c = 1.0 if wcj <= 0.0 else 0.0
            lost_j = 1.0 if wjj <= 0.0 else 0.0
            w0, w1 = a[0] / (wcj + lost_c), a[1] / (wcj + lost_c)
            w2, w3 = a[2] / (wjj + lost_j), a[3] / (wjj + lost_j)
            for i in range(lag):
                for ax in range(2):
                    p0, p1 = past[0, j, i, ax], past[1, j, i, ax]
                    new_c[i, ax] = w0 * p0 + w1 * p1 + lost_c * p0
                    new_j[i, ax] = w2 * p0 + w3 * p1 + lost_j * p1
            for ax in range(2):
                c[j, ax] = (w2 * y[0, ax] + w3 * (c[j, ax] + g * y[2, ax])
                            + lost_j * c[j, ax])
            pc[j] = w2 + w3 * (pc[j] + drift) * (1.0 - g) + lost_j * pc[j]
            for ax in range(2):
                new_c[slot, ax] = 0.0
                new_j[slot, ax] = c[j, ax]
            for i in range(lag):
                for ax in range(2):
                    past[0, j, i, ax] = new_c[i, ax]
                    past[1, j, i, ax] = new_j[i, ax]
            wc[j], wj[j] = wcj, wjj
            for ax in range(2):
                off[t, j, ax] = wjj * c[j, ax]


@numba.njit(cache=True)
def hmm_forward(logf: FloatArray, trans: FloatArray, pi: FloatArray, restart: BoolArray,
                pred_ll: FloatArray, pred: FloatArray, filt: FloatArray) -> None:
    """
    Run the forward filter of a K-state HMM; write its outputs in place.

    ``logf`` (n, K) emission log densities, ``trans`` (K, K), ``pi`` (K,)
    the start, ``restart`` (n,) where the chain starts again from ``pi``.
    Outputs: ``pred_ll`` (n,) one-step predictive log densities, ``pred``
    (n, K) predictive and ``filt`` (n, K) filtered state probabilities.
    """
    n, k = logf.shape
    for t in range(n):
        for j in range(k):
            if t == 0 or restart[t]:
                pred[t, j] = pi[j]
            else:
                acc = 0.0
                for i in range(k):
                    acc += filt[t - 1, i] * trans[i, j]
                pred[t, j] = acc
        top = logf[t, 0]
        for j in range(1, k):
            top = max(top, logf[t, j])
        tot = 0.0
        for j in range(k):
            filt[t, j] = pred[t, j] * math.exp(logf[t, j] - top)
            tot += filt[t, j]
        pred_ll[t] = math.log(tot) + top
        for j in range(k):
            filt[t, j] /= tot


@numba.njit(cache=True)
def hmm_backward(logf: FloatArray, trans: FloatArray, filt: FloatArray, gamma: FloatArray,
                 counts: FloatArray) -> None:
    """
    Run the backward pass after :func:`hmm_forward` (one chain, no restarts).

    Writes ``gamma`` (n, K), the smoothed state probabilities, and adds the
    expected transition counts to ``counts`` (K, K).
    """
    n, k = logf.shape
    beta = np.ones(k) / k
    nxt = np.empty(k)
    fb = np.empty(k)
    for t in range(n - 1, -1, -1):
        if t < n - 1:
            top = logf[t + 1, 0]
            for j in range(1, k):
                top = max(top, logf[t + 1, j])
            for j in range(k):
                fb[j] = math.exp(logf[t + 1, j] - top) * beta[j]
            tot = 0.0
            for i in range(k):
                for j in range(k):
                    tot += filt[t, i] * trans[i, j] * fb[j]
            norm = 0.0
            for i in range(k):
                acc = 0.0
                for j in range(k):
                    counts[i, j] += filt[t, i] * trans[i, j] * fb[j] / tot
                    acc += trans[i, j] * fb[j]
                nxt[i] = acc
                norm += acc
            for i in range(k):
                beta[i] = nxt[i] / norm
        tot = 0.0
        for j in range(k):
            gamma[t, j] = filt[t, j] * beta[j]
            tot += gamma[t, j]
        for j in range(k):
            gamma[t, j] /= tot
