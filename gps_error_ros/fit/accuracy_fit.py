"""
Fit a profile's ``reported_accuracy`` section from what a phone stated.

Reads the trace's ``accuracy`` column (Android's 68 % horizontal radius, m)
or, without it, ``hdop`` (GGA). The model is :mod:`reported`'s:

* ``scale_m`` (HDOP only): an HDOP has no metres, so one factor must be
  chosen; it is the one that makes ``scale_m * hdop`` hold 68 % of the
  trace's true horizontal errors (the 68th percentile of ``|e| / hdop``),
  the radius a receiver with this phone's error and HDOP would state if it
  were calibrated. A phone's stated accuracy is taken as it is.
* ``resolution_m``: the largest power of ten from 10 to 0.001 of which
  every stated value is a multiple (the digits the phone writes: whole
  metres, or an HDOP's hundredths, times ``scale_m``); else 0.
* the error's local scale: the RMS of the one-step innovations
  ``e_k - rho e_(k-1)`` (``rho`` each axis' lag-1 autocorrelation) over the
  31 steps centred at each fix, over its trace-wide RMS: the data's
  counterpart of the model's predictive SD over its reference.
* ``median_m``, ``follow``, ``sigma_log``: maximum likelihood of
  ``log r = log(median_m) + follow * log(scale) + x``, ``x`` normal, each
  stated value read as the interval of radii it rounds from (interval
  censoring: with whole metres a value of 3 is any radius in [2.5, 3.5)).
  One distinct value: ``median_m`` is it and ``sigma_log`` 0.
* ``phi``: unrounded, the lag-1 autocorrelation of ``x`` on consecutive
  steps; rounded, the coefficient under which the stated value changes
  between consecutive fixes as often as it did (simulated moments: rounding
  hides ``x``'s small moves); 0 when ``sigma_log`` is 0.

The evidence beside it: the measured coverage (the share of true errors
inside the stated radius), the distinct values, and the correlation of the
stated log-radius with the error's local log-scale at delays -10..10 s
(does the statement follow the error, and how late?).
"""

import math
from typing import Any, Optional

import numpy as np
from scipy import optimize, special

from gps_error_ros.fit.section_fit import SectionFit
from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.reported import reported_from_dict, ReportedError
from gps_error_ros.model.state import FloatArray, Numbers
from gps_error_ros.traces.trace_io import Trace

MIN_ROWS = 30
WINDOW = 31
_QUANTA = (10.0, 1.0, 0.1, 0.01, 0.001)


def quantum(values: Numbers) -> float:
    """Return the largest power of ten (10 .. 0.001) of which every value is a multiple, or 0."""
    v = np.asarray(values, dtype=float)
    for q in _QUANTA:
        if np.all(np.abs(v / q - np.round(v / q)) < 1e-6):
            return q
    return 0.0


def local_scale(t: Numbers, err: FloatArray, window: int = WINDOW) -> FloatArray:
    """Return each row's local innovation RMS over the trace-wide one (NaN: too few)."""
    t = np.asarray(t, dtype=float)
    next_ok = np.r_[False, np.isclose(np.diff(t), 1.0)]
    u = np.full(err.shape, np.nan)
    for a in range(2):
        e = err[:, a] - np.nanmean(err[:, a])
        prev = np.r_[np.nan, e[:-1]]
        pair = next_ok & np.isfinite(e) & np.isfinite(prev)
        rho = np.sum(e[pair] * prev[pair]) / max(np.sum(prev[pair] ** 2), 1e-12)
        u[pair, a] = e[pair] - rho * prev[pair]
    u2 = np.sum(u ** 2, axis=1)
    out = np.full(t.size, np.nan)
    half = window // 2
    for k in range(t.size):
        near = np.abs(t - t[k]) <= half
        vals = u2[near][np.isfinite(u2[near])]
        if vals.size >= 10:
            out[k] = math.sqrt(np.mean(vals))
    return out / math.sqrt(np.nanmean(u2))


def _bounds(r: FloatArray, q: float) -> tuple[FloatArray, FloatArray]:
    """Return the log-radius interval each stated radius rounds from."""
    if q <= 0:
        return np.log(r), np.log(r)
    lo = np.where(r <= q * (1 + 1e-9), 1e-9, r - 0.5 * q)
    return np.log(lo), np.log(r + 0.5 * q)


def _censored_fit(lo: FloatArray, hi: FloatArray, x: FloatArray) -> tuple[float, float, float]:
    """Return (c, follow, sigma) by maximum likelihood of interval-censored normals."""
    exact = np.allclose(lo, hi)
    mid = 0.5 * (lo + hi)
    design = np.stack([np.ones_like(x), x], axis=1)
    beta = np.linalg.lstsq(design, mid, rcond=None)[0]
    s0 = max(float(np.std(mid - design @ beta)), 1e-3)
    if exact:
        return float(beta[0]), float(beta[1]), float(np.std(mid - design @ beta))

    def nll(p: FloatArray) -> float:
        m, s = design @ p[:2], np.exp(p[2])
        a, b = (lo - m) / s, (hi - m) / s
        prob = 0.5 * (special.erfc(-b / math.sqrt(2)) - special.erfc(-a / math.sqrt(2)))
        return -np.sum(np.log(np.maximum(prob, 1e-300)))

    res = optimize.minimize(nll, np.r_[beta, math.log(s0)], method='Nelder-Mead',
                            options={'xatol': 1e-6, 'fatol': 1e-8, 'maxiter': 4000})
    return float(res.x[0]), float(res.x[1]), float(np.exp(res.x[2]))


def _latent_mean(lo: FloatArray, hi: FloatArray, m: FloatArray, s: float) -> FloatArray:
    """Return E[x | x + m in [lo, hi)] for x ~ N(0, s^2)."""
    if s <= 0:
        return np.zeros_like(m)
    a, b = (lo - m) / s, (hi - m) / s
    z = special.ndtr(b) - special.ndtr(a)
    dens = (np.exp(-0.5 * a ** 2) - np.exp(-0.5 * b ** 2)) / math.sqrt(2 * math.pi)
    return np.where(z > 1e-12, s * dens / np.maximum(z, 1e-12), 0.5 * (lo + hi) - m)


def _phi_through_rounding(changes: float, m: FloatArray, sigma: float, q: float, pair: Any,
                          reps: int = 8, seed: int = 20261123) -> float:
    """
    Return the latent AR(1) coefficient whose rounded radii change as often as measured.

    A radius rounded to ``q`` hides most of ``x``'s small moves, so
    moments of the latent are not seen; what is seen is how often the
    stated value changes between consecutive fixes (``changes``, a share).
    The latent process is simulated on the same rows (means ``m``,
    ``sigma``, pairs, rounding) for a grid of coefficients (common random
    numbers, so the share falls as the coefficient grows), and the
    coefficient giving the measured share is interpolated: a method of
    simulated moments.
    """
    from scipy import signal        # here: about a second to import, for this fit alone
    z = np.random.default_rng(seed).standard_normal((reps, m.size))
    grid = np.linspace(0.0, 0.995, 100)
    shares = []
    for rho in grid:
        x = np.empty_like(z)
        x[:, 0] = z[:, 0]
        x[:, 1:] = signal.lfilter([math.sqrt(1 - rho ** 2)], [1.0, -rho], z[:, 1:],
                                  axis=1, zi=rho * z[:, :1])[0]
        r = np.maximum(np.round(np.exp(m + sigma * x) / q), 1.0) * q
        shares.append(np.mean(r[:, pair] != r[:, pair + 1]))
    share = np.minimum.accumulate(np.asarray(shares))
    return float(np.interp(-changes, -share, grid))


def _follow_lags(t: FloatArray, log_r: FloatArray, log_s: FloatArray) -> dict[int, float]:
    """Return {delay s: correlation of log r(t) with log s(t - delay)} for -10..10 s."""
    out: dict[int, float] = {}
    index = {float(v): i for i, v in enumerate(t)}
    for d in range(-10, 11):
        j = np.array([index.get(float(v) - d, -1) for v in t])
        ok = (j >= 0) & np.isfinite(log_r)
        ok[ok] &= np.isfinite(log_s[j[ok]])
        if ok.sum() < MIN_ROWS or np.std(log_r[ok]) == 0 or np.std(log_s[j[ok]]) == 0:
            continue
        out[d] = round(float(np.corrcoef(log_r[ok], log_s[j[ok]])[0, 1]), 4)
    return out


def _stated(trace: Trace) -> tuple[Optional[str], Any]:
    """Return (source, stated values) of the trace, or (None, reason)."""
    for source in ('accuracy', 'hdop'):
        v = trace.extra.get(source)
        if v is not None and np.sum(np.isfinite(v) & (v > 0)) >= MIN_ROWS:
            return source, np.asarray(v, dtype=float)
    return None, (f'no column accuracy or hdop with {MIN_ROWS} positive values')


def estimate_reported(trace: Trace) -> SectionFit:
    """
    Return the reported_accuracy section (or why none) for ``trace`` (see module doc).

    Times are taken on the 1 s grid (a receiver's stamps jitter about whole
    seconds). A fit that cannot be made gives None and the reason, never a
    NaN.
    """
    source, stated = _stated(trace)
    if source is None:
        return SectionFit(None, {'fitted': False, 'reason': stated})
    with np.errstate(all='ignore'):
        section, evidence = _estimate(trace, source, stated)
    bad = [k for k, v in section.items() if isinstance(v, float) and not math.isfinite(v)]
    if bad:
        return SectionFit(None, {'fitted': False,
                                 'reason': f'the fit of {", ".join(bad)} is not finite '
                                           f'({evidence["rows"]} rows with a stated value '
                                           f'and a local error scale; {MIN_ROWS} needed)'})
    try:
        reported_from_dict(section, 'the fit')
    except ReportedError as exc:
        return SectionFit(None, {'fitted': False, 'reason': f'outside the profile schema: {exc}'})
    return SectionFit(section, evidence)


def _estimate(trace: Trace, source: str,
              stated: FloatArray) -> tuple[dict[str, Any], dict[str, Any]]:
    """Return (section, evidence) of :func:`estimate_reported` (values may be NaN)."""
    t = np.rint(trace.t - trace.t[0])
    north, east = difference(trace.lat, trace.lon, trace.truth_lat, trace.truth_lon)
    err = np.stack([north, east], axis=1)
    h = np.hypot(north, east)
    rows = np.isfinite(stated) & (stated > 0) & np.isfinite(h)
    scale_m = float(np.quantile(h[rows] / stated[rows], 0.68)) if source == 'hdop' else 0.0
    r = stated * (scale_m if source == 'hdop' else 1.0)
    q = quantum(stated[rows]) * (scale_m if source == 'hdop' else 1.0)
    ls = np.log(local_scale(t, err))
    use = rows & np.isfinite(ls)
    if use.sum() < MIN_ROWS:
        return {'sigma_log': math.nan}, {'rows': int(use.sum())}
    lo, hi = _bounds(r[use], q)
    if np.unique(r[use]).size == 1:
        c, follow, sigma = math.log(r[use][0]), 0.0, 0.0
    else:
        c, follow, sigma = _censored_fit(lo, hi, ls[use])
        if not -3.0 <= follow <= 3.0:
            # a slope out of bounds (local scales that hardly vary): the level
            # refitted at the bound, or it is the extrapolation of the wild one
            follow = float(min(max(follow, -3.0), 3.0))
            shift = follow * ls[use]
            c, _, sigma = _censored_fit(lo - shift, hi - shift, np.zeros_like(shift))
    x = _latent_mean(lo, hi, c + follow * ls[use], sigma)
    tu = t[use]
    pair = np.flatnonzero(np.isclose(np.diff(tu), 1.0))
    phi = 0.0
    if sigma > 0 and pair.size and q <= 0:
        phi = float(np.mean(x[pair] * x[pair + 1]) / sigma ** 2)
    elif sigma > 0 and pair.size:
        ru = r[use]
        phi = _phi_through_rounding(float(np.mean(ru[pair] != ru[pair + 1])),
                                    c + follow * ls[use], sigma, q, pair)
    n_eff = use.sum() * (1 - min(abs(phi), 0.99)) / (1 + min(abs(phi), 0.99))
    sd_ls = float(np.std(ls[use]))
    follow_se = sigma / (sd_ls * math.sqrt(n_eff)) if sd_ls > 0 and sigma > 0 else None
    section = {'source': source, 'median_m': round(float(np.exp(c)), 6),
               'follow': round(follow, 6), 'phi': round(min(max(phi, 0.0), 0.999), 6),
               'sigma_log': round(sigma, 6), 'resolution_m': round(q, 6),
               'scale_m': round(scale_m, 6)}
    values, counts = np.unique(stated[rows], return_counts=True)
    evidence = {'fitted': True, 'rows': int(use.sum()),
                'follow_se': None if follow_se is None else round(follow_se, 4),
                'coverage_measured': round(float(np.mean(h[rows] <= r[rows])), 4),
                'distinct_values': int(values.size),
                'most_common': [[float(v), int(n)] for v, n in
                                sorted(zip(values, counts), key=lambda p: -p[1])[:5]],
                'corr_log_radius_log_scale_by_delay_s':
                    _follow_lags(t, np.log(np.where(rows, r, np.nan)), ls)}
    return section, evidence
