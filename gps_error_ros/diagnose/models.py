"""
A fitted model of the diagnosis: mean part, innovation law, its measures.

Estimation, the same for every model: conditional quasi-maximum likelihood
in two stages. (1) The mean part (delta, phi and, with ``motion_lag``, the
lag) maximises the conditional Gaussian likelihood, i.e. least squares;
(2) the innovation law (covariances, correlation, dof, regimes) maximises
the likelihood of the stage-1 innovations. With ``periodic`` the mean
part has one constant per phase of the cycle, and the innovations are
divided by their phase's scale (the root mean square of the phase's
standardised innovations, averaging 1 in square) before the law is fitted;
the likelihood carries the Jacobian of that division. With ``outliers``
the mean part predicts from the past with its jumps set aside, and the
likelihood is the filter's mixture (:mod:`.jumps`).
"""

from collections.abc import Collection, Sequence
from dataclasses import dataclass, replace
import math
from typing import Any, Optional

import numpy as np

from gps_error_ros.diagnose import jumps
from gps_error_ros.diagnose.common import DiagnosisError, EFFECT_ORDER, Orders
from gps_error_ros.diagnose.jumps import JumpFilter
from gps_error_ros.diagnose.laws import fit_law, Law, law_logpdf, law_logpdf_given, robust_cov
from gps_error_ros.diagnose.mean import (Design, design, fit_mean, fit_mean_gain,
                                         fit_mean_lag, least_squares, MeanFit,
                                         to_travel_frame)
from gps_error_ros.fit.holdout import Part, TruthTrack
from gps_error_ros.fit.calibration import CalibrationError, fit_axis
from gps_error_ros.model.ar_model import AXES, AxisParams, ModelError
from gps_error_ros.model.effect_kinds.variance_regimes import Regimes
from gps_error_ros.model.effects import build_model, Effects, stationary_distribution
from gps_error_ros.model.outliers import Outliers
from gps_error_ros.model.periodic import Periodic
from gps_error_ros.model.protocol import OpaqueProcess
from gps_error_ros.model.state import FloatArray, IntArray


@dataclass
class FittedModel:
    """A fitted (base or extended) model on the training part."""

    effects: tuple[str, ...]
    orders: tuple[int, ...]
    mean: MeanFit
    law: Law
    train_loglik: float
    n_train: int
    cycle_scales: Optional[np.ndarray] = None     # periodic: (period,) innovation SD by phase
    jumps: Optional[Outliers] = None      # outliers: rate, mean length, size

    @property
    def n_params(self) -> int:
        """Return the number of free parameters."""
        return sum(p + 1 for p in self.orders) + self.law.n_params + \
            int('motion_lag' in self.effects) + 3 * max(self.mean.period - 1, 0) + \
            3 * (self.jumps is not None)

    @property
    def bic(self) -> float:
        """Return the training BIC."""
        return -2 * self.train_loglik + self.n_params * math.log(self.n_train)

    def axis_params(self) -> tuple[AxisParams, AxisParams]:
        """Return per-axis :class:`AxisParams` (sigma_w of the unit regime)."""
        out = []
        for a in range(2):
            phi = tuple(float(v) for v in self.mean.phi[a])
            out.append(AxisParams(float(self.mean.const[a]), phi,
                                  float(math.sqrt(self.law.cov[a, a]))))
        return out[0], out[1]

    def effects_obj(self) -> Effects:
        """Return the model's :class:`Effects`."""
        cov = self.law.cov
        params: dict[str, Any] = {}
        if 'cross_axis_coupling' in self.effects:
            params['cross_axis_coupling'] = float(cov[0, 1] / math.sqrt(cov[0, 0] * cov[1, 1]))
        if 'motion_lag' in self.effects:
            params['motion_lag'] = float(self.mean.lag_s)
        if 'heavy_tails' in self.effects:
            params['heavy_tails'] = float(self.law.dof)
        if 'street_frame' in self.effects:
            params['street_frame'] = (float(math.sqrt(cov[0, 0])), float(math.sqrt(cov[1, 1])))
        if 'variance_regimes' in self.effects:
            params['variance_regimes'] = Regimes(
                tuple(float(v) for v in self.law.scales),
                tuple(tuple(float(v) for v in row) for row in self.law.transition))
        if 'periodic' in self.effects and self.cycle_scales is not None \
                and self.mean.offsets is not None:
            params['periodic'] = Periodic(
                int(self.mean.period), tuple(float(v) for v in self.cycle_scales),
                tuple((float(a), float(b)) for a, b in self.mean.offsets))
        if self.jumps is not None:
            params['outliers'] = Outliers(float(self.jumps.rate), float(self.jumps.mean_steps),
                                          float(self.jumps.sigma_m))
        return Effects(params)

    def simulator(self) -> OpaqueProcess:
        """Return the model as a simulator: plain AR, or with its effects."""
        return build_model(*self.axis_params(), self.effects_obj())

    def parameters(self) -> dict[str, Any]:
        """Return the parameters as plain data (profile ``axes`` and ``effects``)."""
        out: dict[str, Any] = {}
        for ax, p in zip(AXES, self.axis_params()):
            out[ax] = {'delta': round(p.delta, 6),
                       'phi': [round(v, 6) for v in p.phi],
                       'sigma_w': round(p.sigma_w, 6)}
        eff = self.effects_obj().to_dict()
        if eff:
            out['effects'] = eff
        return out

    def score(self, part: Part, truth: TruthTrack, m0: int | None = None) -> tuple[Any, ...]:
        """
        Return (per-sample predictive log densities, residuals, design, pred).

        With ``street_frame`` the residuals are along and across the
        direction of travel (the axes of the law). With ``outliers`` the log
        densities are of every scored sample, the residuals, design and
        ``pred`` of the steps the jumps leave clean, with a new segment after
        each jump (:meth:`~.JumpFilter.aside`).

        ``m0``: samples per segment conditioned on, not scored (default: the
        model's own :func:`~.mean.condition_count`); ``pred`` holds the
        predictive regime probabilities (n, K).
        """
        d = design(part, self.orders, truth, self.mean.lag_s, self.mean.gain, m0=m0)
        r = self.mean.residuals(d)
        if self.jumps is not None:
            return self._score_jumps(r, d)
        ll, r, pred = self._law_score(r, d)
        return ll, r, d, pred

    def _law_score(self, r: FloatArray, d: Design,
                   pred: FloatArray | None = None) -> tuple[FloatArray, FloatArray, FloatArray]:
        """
        Return (log densities, residuals in the law's frame and scale, pred).

        ``pred``: the predictive regime probabilities to score with (by
        default those of the regimes' own pass over ``r``).
        """
        if 'street_frame' in self.effects:      # the law is along/across the travel
            r = to_travel_frame(r, d.heading)
        r, log_jac = cycle_scaled(r, d, self.mean.period, self.cycle_scales)
        if pred is None:
            ll, pred = law_logpdf(self.law, r, d.seg)
        else:
            ll = law_logpdf_given(self.law, r, pred)
        return ll - log_jac, r, pred

    def jump_filter(self, part: Part, truth: TruthTrack) -> tuple[JumpFilter, Design]:
        """Return (the jump filter's pass over ``part``, its design); needs ``outliers``."""
        d = design(part, self.orders, truth, self.mean.lag_s, self.mean.gain)
        return self._jump_pass(self.mean.residuals(d), d), d

    def _jump_pass(self, r_obs: FloatArray, d: Design) -> JumpFilter:
        if self.jumps is None:
            raise DiagnosisError('the jump filter needs a model with outliers')
        cov = average_cov(self.law, self.effects)
        scale2 = cycle_scale2(d, self.mean.period, self.cycle_scales)
        return jumps.run_filter(r_obs, d.seg, self.mean.phi, cov, self.jumps, scale2,
                                self.law.dof)

    def _score_jumps(self, r_obs: FloatArray, d: Design, residuals: bool = True) -> Any:
        """Score through the jump filter; the residuals returned are the clean steps'."""
        jf = self._jump_pass(r_obs, d)
        ll, pred = self._jump_loglik(jf, d)
        if not residuals:
            return ll
        # the tests see the clean steps only, with a segment break at each jump;
        # the regimes run over them as the law was fitted, without the breaks
        keep = ~jf.aside()
        dk = jumps.design_subset(d, keep)
        _, r, pred = self._law_score(jf.r[keep], dk)
        return ll, r, replace(dk, seg=jumps.broken_segments(d.seg, keep)), pred

    def _jump_loglik(self, jf: JumpFilter, d: Design) -> tuple[FloatArray, FloatArray]:
        """
        Return (per-sample log densities, regime probabilities) of one filter pass.

        The regimes run over the residuals given clean; the residuals from
        each state's past are scored with their predictive probabilities.
        """
        pred = self._law_score(jf.r, d)[2] if self.law.scales.size > 1 else \
            np.ones((len(jf.r), 1))
        clean_ll = [self._law_score(jf.r_from[:, s], d, pred)[0] for s in (0, 1)]
        return jumps.mixture_logpdf(jf, np.column_stack(clean_ll)), pred

    def jump_logliks(self, r_obs: FloatArray, d: Design,
                     cands: Sequence[tuple[Outliers, float]]) -> list[float]:
        """Return the training log likelihood of each candidate ``(Outliers, dof)``."""
        cov = average_cov(self.law, self.effects)
        scale2 = cycle_scale2(d, self.mean.period, self.cycle_scales)
        jfs = jumps.run_filters(r_obs, d.seg, self.mean.phi, cov, cands, scale2)
        return [float(np.sum(replace(self, jumps=p, law=replace(self.law, dof=dof))
                             ._jump_loglik(jf, d)[0]))
                for (p, dof), jf in zip(cands, jfs)]


def average_cov(law: Law, effects: Collection[str]) -> FloatArray:
    """Return the innovations' covariance (north/east) averaged over regimes and directions."""
    cov = law.cov
    if 'street_frame' in effects:           # along/across: averaged over directions
        cov = np.eye(2) * 0.5 * np.trace(cov)
    return cov * float(stationary_distribution(law.transition) @ law.scales ** 2)


def phase_scales(r: FloatArray, phase: IntArray, period: int) -> FloatArray:
    """Return the innovations' SD by phase (standardised per axis; mean square 1)."""
    q = np.mean(r * r / np.mean(r * r, axis=0), axis=1)
    ms = np.bincount(phase, weights=q, minlength=period) / \
        np.maximum(np.bincount(phase, minlength=period), 1)
    ms = np.where(ms > 0, ms, 1.0)
    return np.sqrt(ms / ms.mean())


def robust_phase_scales(r: FloatArray, phase: IntArray, period: int) -> FloatArray:
    """
    Return the innovations' SD by phase as :func:`phase_scales`, from medians of squares.

    A jump of the fix leaves a squared innovation hundreds of times the
    others': in the mean square of its phase it is that phase's burst, in
    the median it is one sample among hundreds.
    """
    q = np.mean(r * r / np.median(r * r, axis=0), axis=1)
    med = np.array([np.median(q[phase == k]) if np.any(phase == k) else 0.0
                    for k in range(period)])
    med = np.where(med > 0, med, 1.0)
    return np.sqrt(med / med.mean())


def cycle_scale2(d: Design, period: int, scales: FloatArray | None) -> FloatArray | None:
    """Return each sample's squared phase scale (None without a cycle)."""
    return scales[d.phase(period)] ** 2 if period and scales is not None else None


def cycle_scaled(r: FloatArray, d: Design, period: int,
                 scales: FloatArray | None) -> tuple[FloatArray, FloatArray | float]:
    """Return (``r`` divided by its phase's scale, the log Jacobian per sample)."""
    if not period or scales is None:
        return r, 0.0
    s = scales[d.phase(period)]
    return r / s[:, None], 2.0 * np.log(s)


def with_law(effects: Collection[str], orders: Orders, mean: MeanFit, r: FloatArray, d: Design,
             regimes: int) -> FittedModel:
    """Return the :class:`FittedModel` of a mean part with its law fitted on ``r``."""
    if 'street_frame' in effects:
        r = to_travel_frame(r, d.heading)
    scales = phase_scales(r, d.phase(mean.period), mean.period) if mean.period else None
    r, log_jac = cycle_scaled(r, d, mean.period, scales)
    law = fit_law(r, d.seg, coupled='cross_axis_coupling' in effects,
                  tails='heavy_tails' in effects,
                  regimes=regimes if 'variance_regimes' in effects else 0)
    ll = float(np.sum(law_logpdf(law, r, d.seg)[0] - log_jac))
    return FittedModel(tuple(e for e in EFFECT_ORDER if e in effects),
                       tuple(orders), mean, law, ll, len(r), scales)


#: Training samples the jump parameters' search scores at most (longer
#: recordings: :data:`SEARCH_BLOCKS` blocks spread evenly over them).
SEARCH_SAMPLES = 4000
SEARCH_BLOCKS = 6


def search_sample(r: FloatArray, d: Design, limit: int = SEARCH_SAMPLES,
                  blocks: int = SEARCH_BLOCKS) -> tuple[FloatArray, Design]:
    """
    Return the residuals and design (``r``, ``d``) the parameter search scores.

    Up to ``limit`` samples: all of them, unchanged. Beyond, ``blocks``
    contiguous blocks of ``limit // blocks`` samples spread evenly over the
    part, each block its own segment (no filter step spans two). The search finds
    the likelihood's maximum; its precision is that of ``limit`` samples,
    and its cost stops growing with the recording (a day at 1 Hz has 60,000
    training samples). The filter then runs over every sample.
    """
    n = len(r)
    if n <= limit:
        return r, d
    size = limit // blocks
    keep = np.zeros(n, dtype=bool)
    for start in np.linspace(0, n - size, blocks).astype(int):
        keep[start:start + size] = True
    sub = jumps.design_subset(d, keep)
    sub.seg = jumps.broken_segments(d.seg, keep)
    return np.asarray(r)[keep], sub


def with_jumps(effects: Collection[str], orders: Orders, mean: MeanFit, r: FloatArray, d: Design,
               regimes: int) -> FittedModel:
    """
    Return the :class:`FittedModel` with ``outliers`` (see :mod:`.jumps`).

    The jumps are set aside by the filter, the mean part refitted on the
    rest and the law fitted on the clean steps; the jump parameters (and
    with ``heavy_tails`` the tails' dof, weighed with them) are then
    searched over a wide grid; with them the jumps are set aside again, the
    mean part and the law refitted, and the search refined around the best.
    """
    cov, dof = robust_cov(r), math.inf
    scale2: FloatArray | None = None
    sd = math.sqrt(0.5 * np.trace(cov))
    params = Outliers(jumps.START[0], jumps.START[1], jumps.START[2] * sd)
    others = tuple(e for e in effects if e != 'outliers')
    tails = 'heavy_tails' in effects
    for wide in (True, False):
        jf = jumps.run_filter(r, d.seg, mean.phi, cov, params, scale2, dof)
        if wide:
            params = jumps.moment_start(jf, cov) or params
        mean, _ = least_squares(jumps.cleaned_design(d, jf.offset), mean.lag_s, mean.gain,
                                mean.period)
        r = mean.residuals(d)
        jf = jumps.run_filter(r, d.seg, mean.phi, cov, params, scale2, dof)
        keep = jf.inside < jumps.ASIDE
        # the law of the clean steps: the filter's next pass knows its scale by
        # phase (or a cycle's bursts pass for jumps) and its tails (or a large
        # innovation, which persists, passes for a jump, which does not)
        model = replace(with_law(others, orders, mean, jf.r[keep],
                                 jumps.design_subset(d, keep), regimes),
                        effects=tuple(e for e in EFFECT_ORDER if e in effects))
        cov = average_cov(model.law, others)
        scale2 = cycle_scale2(d, mean.period, model.cycle_scales)
        sd = math.sqrt(0.5 * np.trace(cov))
        rs, ds = search_sample(r, d)
        params, dof = jumps.search_params(lambda c: model.jump_logliks(rs, ds, c), sd, params,
                                          model.law.dof, tails, wide)
    model = replace(model, jumps=params, law=replace(model.law, dof=dof))
    return replace(model, train_loglik=float(np.sum(model._score_jumps(r, d, False))),
                   n_train=len(r))


def fit_model(train: Part, orders: Orders, effects: Collection[str], truth: TruthTrack,
              lag_s: float | None = None, regimes: int = 2, period: int = 0) -> FittedModel:
    """
    Fit a model with ``effects`` (names) on the training part.

    With ``motion_lag``, ``lag_s`` is estimated unless given; ``regimes`` is
    the number of variance levels when ``variance_regimes`` is present, and
    ``period`` the cycle's length (steps) when ``periodic`` is.
    """
    period = int(period) if 'periodic' in effects else 0
    if 'periodic' in effects and period < 2:
        raise DiagnosisError(f'periodic needs a period of 2 or more steps, got {period}')
    if 'motion_lag' not in effects:
        mean, r, d = fit_mean(train, orders, truth, period=period)
    elif lag_s is None:
        mean, r, d = fit_mean_lag(train, orders, truth, period)
    else:
        mean, r, d = fit_mean(train, orders, truth, lag_s, period=period)
    if 'outliers' in effects:
        return with_jumps(effects, orders, mean, r, d, regimes)
    return with_law(effects, orders, mean, r, d, regimes)


def fit_motion_probe(train: Part, orders: Orders, truth: TruthTrack,
                     lag_s: float) -> FittedModel:
    """Fit the motion test's model at lag ``lag_s``: gain >= 0 estimated."""
    mean, r, d = fit_mean_gain(train, orders, truth, lag_s)
    return with_law(('motion_lag',), orders, mean, r, d, 0)


def score(model: FittedModel, part: Part, truth: TruthTrack,
          m0: int | None = None) -> tuple[Any, ...]:
    """Return :meth:`FittedModel.score` (a function, for baselines' symmetry)."""
    return model.score(part, truth, m0)


def select_orders(train: Part) -> tuple[int, int]:
    """Return the PACF-rule orders of the training part (as calibration)."""
    orders = []
    for a, ax in enumerate(AXES):
        try:
            orders.append(fit_axis([e[:, a] for e in train.err], axis=ax)
                          .params.order)
        except (CalibrationError, ModelError) as exc:
            raise DiagnosisError(f'training part: {exc}') from None
    return orders[0], orders[1]
