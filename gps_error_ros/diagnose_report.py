"""Figures of ``gps_error diagnose``: the residual structure, before and after."""

import math

import numpy as np
from scipy import stats

from .diagnose import _pooled_acf, mahalanobis, pit_radial, standardised

MAX_LAG = 30


def _base_z(diag):
    r, seg = diag.train_residuals['base']
    return r / np.sqrt(np.diag(diag.base.law.cov)), seg


def _ext_z(diag):
    r, seg, pred = diag.train_residuals['extended']
    return standardised(diag.extended, r, pred), seg, r, pred


def diagnosis_figure(diag, path, title):
    """Write a 2x2 PNG: innovation ACF, north-east scatter, QQ, squared ACF."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    zb, segb = _base_z(diag)
    ze, sege, re, pred = _ext_z(diag)
    extended = diag.extended is not diag.base
    n = len(zb)
    band = 1.96 / math.sqrt(n)
    lags = np.arange(1, MAX_LAG + 1)
    fig, ax = plt.subplots(2, 2, figsize=(12, 9))
    fig.suptitle(f'{title}: training innovations, base model'
                 + (' and extended model' if extended else ''), fontsize=11)

    a = ax[0, 0]
    for i, (name, colour) in enumerate((('north', 'C0'), ('east', 'C1'))):
        a.plot(lags, _pooled_acf(zb[:, i], segb, MAX_LAG), 'o-', ms=3,
               color=colour, label=f'{name}, base')
        if extended:
            a.plot(lags, _pooled_acf(ze[:, i], sege, MAX_LAG), 's--', ms=3,
                   color=colour, alpha=0.5, label=f'{name}, extended')
    a.axhspan(-band, band, color='0.85', label='95 % band, white noise')
    a.axhline(0, color='k', lw=0.5)
    a.set(title='innovation autocorrelation', xlabel='lag (s)', ylabel='ACF')
    a.legend(fontsize=8)

    a = ax[0, 1]
    r0 = diag.train_residuals['base'][0]
    a.plot(r0[:, 1], r0[:, 0], '.', ms=2, alpha=0.4, color='0.3')
    t = np.linspace(0, 2 * np.pi, 200)
    for cov, label, colour in ((np.cov(r0.T), 'sample covariance', 'C3'),
                               (diag.base.law.cov, 'base model', 'C0'),
                               (diag.extended.law.cov * float(
                                   np.mean(pred @ diag.extended.law.scales ** 2)),
                                'extended model', 'C2')):
        w, v = np.linalg.eigh(cov)
        pts = v @ (2.0 * np.sqrt(w)[:, None] * np.stack([np.cos(t), np.sin(t)]))
        a.plot(pts[1], pts[0], color=colour, label=f'2-sigma, {label}')
    rho = np.corrcoef(r0.T)[0, 1]
    a.set(title=f'north-east innovations (correlation {rho:.3f})',
          xlabel='east innovation (m)', ylabel='north innovation (m)')
    a.set_aspect('equal', 'datalim')
    a.legend(fontsize=8)

    a = ax[1, 0]
    q = (np.arange(1, n + 1) - 0.5) / n
    theo = stats.norm.ppf(q)
    for i, (name, colour) in enumerate((('north', 'C0'), ('east', 'C1'))):
        a.plot(theo, np.sort(zb[:, i]), '.', ms=2, color=colour,
               label=f'{name}, base (standardised)')
    if extended:
        u = np.clip(pit_radial(diag.extended, re, pred), 1e-12, 1 - 1e-12)
        # radius PIT -> a normal score, for a tail check of the extended model
        score = stats.norm.ppf(np.sort(u))
        a.plot(stats.norm.ppf((np.arange(1, len(u) + 1) - 0.5) / len(u)), score,
               '.', ms=2, color='C2',
               label='extended: normal score of the radius PIT')
    lim = [theo[0], theo[-1]]
    a.plot(lim, lim, 'k-', lw=0.8)
    a.set(title='QQ against the normal', xlabel='normal quantile',
          ylabel='sample quantile')
    a.legend(fontsize=8)

    a = ax[1, 1]
    d2 = mahalanobis(r0 - r0.mean(axis=0), np.cov(r0.T, bias=True))
    a.plot(lags, _pooled_acf(stats.rankdata(d2), segb, MAX_LAG), 'o-', ms=3,
           color='C3', label='base')
    if extended:
        u = pit_radial(diag.extended, re, pred)
        a.plot(lags, _pooled_acf(stats.rankdata(u), sege, MAX_LAG), 's--',
               ms=3, color='C2', label='extended (radius PIT)')
    a.axhspan(-band, band, color='0.85', label='95 % band, no persistence')
    a.axhline(0, color='k', lw=0.5)
    a.set(title='persistence of squared innovations (ACF of ranks)',
          xlabel='lag (s)', ylabel='ACF')
    a.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
