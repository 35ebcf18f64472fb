"""Figures of ``gps_error diagnose``: the residual structure, before and after."""

import math
from typing import Any

import numpy as np
from scipy import stats

from gps_error_ros.diagnose.family import pit_radial, standardised
from gps_error_ros.diagnose.laws import mahalanobis
from gps_error_ros.diagnose.pipeline import Diagnosis
from gps_error_ros.fit.autocorrelation import segment_acf
from gps_error_ros.model.atomic import PathArg
from gps_error_ros.model.state import FloatArray, IntArray

MAX_LAG = 30


def _base_z(diag: Diagnosis) -> tuple[FloatArray, IntArray]:
    r, seg = diag.train_residuals['base']
    return r / np.sqrt(np.diag(diag.base.law.cov)), seg


def _ext_z(diag: Diagnosis) -> tuple[FloatArray, IntArray, FloatArray, FloatArray]:
    r, seg, pred = diag.train_residuals['extended']
    return standardised(diag.extended, r, pred), seg, r, pred


class _Views:
    """The innovations and their summaries that the panels draw."""

    def __init__(self, diag: Diagnosis) -> None:
        self.diag = diag
        self.zb, self.segb = _base_z(diag)
        self.ze, self.sege, self.re, self.pred = _ext_z(diag)
        self.extended = diag.extended is not diag.base
        self.n = len(self.zb)
        self.band = 1.96 / math.sqrt(self.n)
        self.lags = np.arange(1, MAX_LAG + 1)


def _acf_panel(a: Any, v: _Views) -> None:
    """Draw the innovation autocorrelation per axis, base (and extended)."""
    for i, (name, colour) in enumerate((('north', 'C0'), ('east', 'C1'))):
        a.plot(v.lags, segment_acf(v.zb[:, i], v.segb, MAX_LAG), 'o-', ms=3,
               color=colour, label=f'{name}, base')
        if v.extended:
            a.plot(v.lags, segment_acf(v.ze[:, i], v.sege, MAX_LAG), 's--', ms=3,
                   color=colour, alpha=0.5, label=f'{name}, extended')
    a.axhspan(-v.band, v.band, color='0.85', label='95 % band, white noise')
    a.axhline(0, color='k', lw=0.5)
    a.set(title='innovation autocorrelation', xlabel='lag (s)', ylabel='ACF')
    a.legend(fontsize=8)


def _scatter_panel(a: Any, v: _Views) -> None:
    """Draw the north-east innovations with 2-sigma ellipses."""
    r0 = v.diag.train_residuals['base'][0]
    a.plot(r0[:, 1], r0[:, 0], '.', ms=2, alpha=0.4, color='0.3')
    t = np.linspace(0, 2 * np.pi, 200)
    for cov, label, colour in ((np.cov(r0.T), 'sample covariance', 'C3'),
                               (v.diag.base.law.cov, 'base model', 'C0'),
                               (v.diag.extended.law.cov * float(
                                   np.mean(v.pred @ v.diag.extended.law.scales ** 2)),
                                'extended model', 'C2')):
        w, vecs = np.linalg.eigh(cov)
        pts = vecs @ (2.0 * np.sqrt(w)[:, None] * np.stack([np.cos(t), np.sin(t)]))
        a.plot(pts[1], pts[0], color=colour, label=f'2-sigma, {label}')
    # The sample correlation of the base model's innovations; the profile's
    # innovation_corr is the fitted law's (maximum likelihood, weighted by the
    # regimes' scales when there are regimes), so the two may differ.
    rho = np.corrcoef(r0.T)[0, 1]
    law = v.diag.extended.law.cov
    fitted = law[0, 1] / np.sqrt(law[0, 0] * law[1, 1])
    a.set(title=f'north-east innovations: sample correlation {rho:.3f}\n'
                f'(base model); fitted innovation_corr {fitted:.3f} (extended)',
          xlabel='east innovation (m)', ylabel='north innovation (m)')
    a.set_aspect('equal', 'datalim')
    a.legend(fontsize=8)


def _qq_panel(a: Any, v: _Views) -> None:
    """Draw the QQ plot against the normal (extended: score of the radius PIT)."""
    q = (np.arange(1, v.n + 1) - 0.5) / v.n
    theo = stats.norm.ppf(q)
    for i, (name, colour) in enumerate((('north', 'C0'), ('east', 'C1'))):
        a.plot(theo, np.sort(v.zb[:, i]), '.', ms=2, color=colour,
               label=f'{name}, base (standardised)')
    if v.extended:
        u = np.clip(pit_radial(v.diag.extended, v.re, v.pred), 1e-12, 1 - 1e-12)
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


def _persistence_panel(a: Any, v: _Views) -> None:
    """Draw the persistence of the squared innovations: ACF of their ranks."""
    r0 = v.diag.train_residuals['base'][0]
    d2 = mahalanobis(r0 - r0.mean(axis=0), np.cov(r0.T, bias=True))
    a.plot(v.lags, segment_acf(stats.rankdata(d2), v.segb, MAX_LAG), 'o-', ms=3,
           color='C3', label='base')
    if v.extended:
        u = pit_radial(v.diag.extended, v.re, v.pred)
        a.plot(v.lags, segment_acf(stats.rankdata(u), v.sege, MAX_LAG), 's--',
               ms=3, color='C2', label='extended (radius PIT)')
    a.axhspan(-v.band, v.band, color='0.85', label='95 % band, no persistence')
    a.axhline(0, color='k', lw=0.5)
    a.set(title='persistence of squared innovations (ACF of ranks)',
          xlabel='lag (s)', ylabel='ACF')
    a.legend(fontsize=8)


def diagnosis_figure(diag: Diagnosis, path: PathArg, title: str) -> PathArg:
    """Write a 2x2 PNG: innovation ACF, north-east scatter, QQ, squared ACF."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    v = _Views(diag)
    fig, ax = plt.subplots(2, 2, figsize=(12, 9))
    fig.suptitle(f'{title}: training innovations, base model'
                 + (' and extended model' if v.extended else ''), fontsize=11)
    for a, panel in zip(ax.ravel(), (_acf_panel, _scatter_panel, _qq_panel,
                                     _persistence_panel)):
        panel(a, v)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
