"""
Close the loop: find what the AR model misses in a trace, and add it.

``gps_error diagnose`` is the list of steps in :func:`diagnose`, every
choice made on the training part alone:

1. :func:`split_step`: the errors on the 1 Hz grid, cut in time (the first
   70 % of the span trains, the rest is held out and used once, to report;
   :mod:`.split`). The first ``condition_count`` samples of every segment
   are conditioned on and not scored, by every model compared (the largest
   order among them counts).
2. :func:`fit_base`: the paper's model, per axis AR(p) with the order the
   PACF rule of calibration picks on the training part, independent
   Gaussian innovations (:mod:`.models`).
3. :func:`run_family`: the test family on the base model's innovations,
   Holm at family-wise level ``alpha`` times ``FIRST_SHARE`` (10/15;
   :mod:`.family`). The retest of step 6 has the rest, so the whole
   diagnosis reports structure that is not there with probability at most
   ``alpha``, 5 % by default.
4. :func:`attribute`: ``cross_axis_correlation`` -> ``cross_axis_coupling``;
   ``motion_dependence`` -> ``motion_lag``; ``travel_frame`` -> fixed axes
   (``cross_axis_coupling``) or axes along/across the travel
   (``street_frame``), the training BIC deciding. Tails and regimes compete: both
   fatten the marginal tails, only regimes make the squared innovations
   persist. With persistence, ``variance_regimes``, the training BIC choosing
   among 2 levels, 3 levels and 2 levels plus Student-t innovations (then
   ``heavy_tails`` too); with excess kurtosis and no persistence,
   ``heavy_tails``. When the motion test rejects on its own, the law is
   tested on the innovations with the lag removed (lag transients would
   otherwise look like tails). ``jump_reversal`` -> ``outliers``; the
   models with it have the AR orders the PACF rule picks on the series with
   its jumps taken out (a jump looks like a loss of persistence), and the
   law's and the motion test see the steps the jumps leave clean. Serial
   correlation that no effect explains, and periodic variance: ``unexplained``.
5. :func:`~.selection.select_effects` and :func:`fit_extended`: every
   subset of the attributed effects is scored by blocked cross-validation
   over the training part (one-step NLL, with a veto on the CRPS of the
   simulated measures; :mod:`.selection`), and the extended model has the subset kept.
6. :func:`retest_extended`: its own innovations tested again; what remains
   is ``unexplained`` (or an approximation of an effect already present).
7. :func:`heldout_measures`: one-step predictive NLL per held-out sample
   before and after (with a block-bootstrap interval of the difference), and
   the fidelity of simulated traces (:mod:`.fidelity`).

Estimation is conditional quasi-maximum likelihood in two stages (mean part
by least squares, innovation law by maximum likelihood; :mod:`.models`).
"""

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
import math
from typing import Any, TypeVar

import numpy as np

from gps_error_ros.diagnose import jumps
from gps_error_ros.diagnose.attribution import (attribute, Attribution, RETEST_EFFECTS,
                                                RETEST_LABEL, travel_axes_win)
from gps_error_ros.diagnose.common import (ALPHA, DiagnosisError, FAMILY_ALPHA, FIRST_SHARE,
                                           MIN_TEST, MIN_TRAIN, MOTION_TEST_LAGS, N_TESTS,
                                           Orders, RETEST_ALPHA, round_levels, TRAIN_FRACTION)
from gps_error_ros.diagnose.findings import (Approximation, EffectFound, Findings, HeldOut,
                                             Improvement, Left, ModelFound, Outcome)
from gps_error_ros.diagnose.family import (FamilyResult, holm_tests, innovation_tests,
                                           jump_reversal_test, motion_test, periodicity_test,
                                           retest, travel_frame_test)
from gps_error_ros.fit.fidelity import block_bootstrap_mean, fidelity
from gps_error_ros.diagnose.mean import (condition_count, Design, design, fit_lag,
                                         from_travel_frame, gain_loss, least_squares, log_det,
                                         motion_correlation, to_travel_frame)
from gps_error_ros.diagnose.models import (fit_model, fit_motion_probe, robust_phase_scales,
                                           FittedModel, select_orders)
from gps_error_ros.diagnose.selection import select_effects, Selection
from gps_error_ros.fit.holdout import Split, split_trace
from gps_error_ros.fit.gross_failures import failures_doc, GrossFailures, without_gross_failures
from gps_error_ros.model.ar_model import AXES
from gps_error_ros.model.profiles import profile_mapping
from gps_error_ros.model.state import FloatArray
from gps_error_ros.traces.trace_io import join_recordings, Trace

ESTIMATION = ('conditional quasi-ML: mean part (delta, phi, lag) by least '
              'squares, innovation law by maximum likelihood')


def rounded(obj: Any) -> Any:
    """Return ``obj`` with floats to 6 significant digits, numpy scalars plain."""
    if isinstance(obj, dict):
        return {k: rounded(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [rounded(v) for v in obj]
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        return v if not math.isfinite(v) else float(f'{v:.6g}')
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


@dataclass
class Diagnosis:
    """
    Everything ``diagnose`` found, with the data needed for figures.

    ``findings`` holds the raw values (:class:`~.findings.Findings`);
    :meth:`to_dict` rounds them for JSON and :meth:`summary` says them for
    the terminal; ``fitted`` holds steps 1-5 (split, base, attribution,
    selection, extended).
    """

    findings: Findings
    fitted: 'FittedModels'
    train_residuals: dict[str, tuple[Any, ...]] = field(default_factory=dict)

    @property
    def split(self) -> Split:
        """Return the :class:`Split` of the diagnosis."""
        return self.fitted.split

    @property
    def base(self) -> FittedModel:
        """Return the base model."""
        return self.fitted.base

    @property
    def extended(self) -> FittedModel:
        """Return the extended model (the base when no effect is kept)."""
        return self.fitted.extended

    def to_dict(self) -> dict[str, Any]:
        """Return the findings as plain data (floats to 6 significant digits)."""
        out: dict[str, Any] = rounded(self.findings.to_dict())
        return out

    def summary(self) -> str:
        """Return what the terminal shows: the split, the tests, the effects, the held-out gain."""
        s = self.findings
        out = [f'{s.input}: {s.samples} samples, {s.train_samples} train / '
               f'{s.test_samples} held out ({s.split_rule})',
               f'  base: AR orders north {s.base.order["north"]}, east '
               f'{s.base.order["east"]}']
        for name, t in s.tests.items():
            flag = ('REJECTED' if t.rejected else 'ok') + \
                (' (by the family with the jumps in)' if t.given else '')
            out.append(f'  test {name:24s} p={t.p_value:.3g} '
                       f'(Holm {t.holm_adjusted_p:.3g}) {flag}')
        out.append('  effects found: ' + (', '.join(s.effect_names) or 'none'))
        if s.effects:
            out.append('  kept for simulation (cross-validated over the training part): '
                       + (', '.join(s.selection.kept) or 'none'))
        unexplained = '; '.join(u.structure for u in s.unexplained)
        out.append('  unexplained: ' + (unexplained or 'none'))
        imp = s.improvement
        out.append(f'  held-out NLL per sample: before '
                   f'{s.error_before.heldout_nll_per_sample:.4f}, after '
                   f'{s.error_after.heldout_nll_per_sample:.4f}; improvement '
                   f'{imp.heldout_nll_per_sample:.4f} (95 % CI {imp.ci95[0]:.4f} .. '
                   f'{imp.ci95[1]:.4f})')
        note = s.note()
        if note:
            out.append('  note: ' + note)
        return '\n'.join(out)


#: The effects that change the mean part (the AR residuals north/east); the others change the law.
MEAN_EFFECTS = ('motion_lag', 'periodic', 'outliers')


def split_step(trace: Trace) -> Split:
    """Step 1: split ``trace``; refuse parts too short to fit or to score."""
    split = split_trace(trace, TRAIN_FRACTION)
    if split.train.n < MIN_TRAIN or split.test.n < MIN_TEST:
        need_s = math.ceil(max(MIN_TRAIN / TRAIN_FRACTION, MIN_TEST / (1 - TRAIN_FRACTION)))
        span_s = float(trace.t[-1] - trace.t[0])
        why = (f'a trace of about {need_s} s or more' if span_s < need_s else
               f'its {span_s:.0f} s would do, but its gaps, gross failures included, '
               f'leave too few')
        raise DiagnosisError(
            f'{trace.name}: {split.train.n} training and {split.test.n} held-out '
            f'samples on the 1 Hz grid; need at least {MIN_TRAIN} and {MIN_TEST} '
            f'({why}; the first {100 * TRAIN_FRACTION:.0f} % of the time trains)')
    return split


def fit_base(split: Split) -> FittedModel:
    """Step 2: the paper's model with the PACF orders of the training part."""
    return fit_model(split.train, select_orders(split.train), (), split.truth)


def _motion_family(split: Split, base: FittedModel, r: FloatArray) -> Outcome:
    """Return the motion test from the probes at 1..5 s (``r``: the base's innovations)."""
    if not _moving(split):
        return motion_test([0.0] * len(MOTION_TEST_LAGS))
    lrs = [2.0 * (fit_motion_probe(split.train, base.orders, split.truth, lag).train_loglik
                  - base.train_loglik) for lag in MOTION_TEST_LAGS]
    return motion_test(lrs, motion_correlation(split.train, base.orders, split.truth,
                                               base.mean.phi, 1.0 / np.var(r, axis=0)))


def _moving(split: Split) -> bool:
    """Return whether the truth of the training part moves at all."""
    return any(np.any(np.abs(np.diff(tr, axis=0)) > 0.05) for tr in split.train.truth)


def _orders_without_jumps(split: Split, jumpy: FittedModel,
                          jf: jumps.JumpFilter) -> tuple[int, int]:
    """Return the PACF-rule orders of the training part with the jumps of pass ``jf`` out."""
    return select_orders(jumps.cleaned_part(split.train, jf.offset,
                                            condition_count(jumpy.orders)))


def _motion_without_jumps(split: Split, jumpy: FittedModel, jf: jumps.JumpFilter,
                          alpha: float) -> tuple[Outcome, float | None]:
    """
    Return the motion test on the training part with the jumps set aside, and its lag.

    The jumps ``jumpy``'s filter pass ``jf`` finds are taken out of the samples and
    their lags, and the steps it sets aside dropped; the likelihood ratios
    at 1..5 s are then those of the Gaussian profile (log-det) loss, as the
    probes'. The lag (gain 1, estimated on the same steps) is None unless
    the test rejects on its own (alpha / m).
    """
    keep = ~jf.aside()

    def clean(d: Design) -> Design:
        return jumps.design_subset(jumps.cleaned_design(d, jf.offset), keep)

    def loss(lag_s: float) -> float:
        return gain_loss(split.train, jumpy.orders, split.truth, lag_s, clean)[0]

    if _moving(split):
        mf, r = least_squares(clean(design(split.train, jumpy.orders, split.truth)))
        null = log_det(r)
        test = motion_test([keep.sum() * max(0.0, null - loss(lag)) for lag in MOTION_TEST_LAGS],
                           motion_correlation(split.train, jumpy.orders, split.truth, mf.phi,
                                              1.0 / np.var(r, axis=0), clean))
    else:
        test = motion_test([0.0] * len(MOTION_TEST_LAGS))
    test = replace(test, test=test.test + ', with the jumps set aside')
    if test.p_value > alpha / N_TESTS:
        return test, None
    return test, fit_lag(split.train, jumpy.orders, split.truth, clean=clean)


def _set_jumps_aside(split: Split, base: FittedModel, effects: tuple[str, ...],
                     lag_s: float | None, period: int,
                     alpha: float) -> tuple[FittedModel, Outcome, float | None]:
    """
    Return (the model the law's tests see, the motion test, the lag) with the jumps aside.

    The model has the mean part found so far (``effects``, ``lag_s``,
    ``period``), Student-t innovations (a large innovation persists, a jump
    does not) and ``outliers``; its AR orders are those the PACF rule picks
    on the series with the jumps out (a jump looks like a loss of
    persistence), and the motion test is taken again on that series (a few
    jumps of metres sway its likelihood ratio): its decision stands for the
    lag.
    """
    fx = effects + ('heavy_tails', 'outliers')
    jumpy = fit_model(split.train, base.orders, fx, split.truth, lag_s, period=period)
    jf, _ = jumpy.jump_filter(split.train, split.truth)
    orders = _orders_without_jumps(split, jumpy, jf)
    if orders != base.orders:
        jumpy = fit_model(split.train, orders, fx, split.truth, lag_s, period=period)
        jf, _ = jumpy.jump_filter(split.train, split.truth)
    motion, clean_lag = _motion_without_jumps(split, jumpy, jf, alpha)
    if clean_lag != lag_s:
        fx = tuple(e for e in fx if e != 'motion_lag') + ('motion_lag',) * (clean_lag is not None)
        jumpy = fit_model(split.train, orders, fx, split.truth, clean_lag, period=period)
    return jumpy, motion, clean_lag


def _robust_cycle(r: FloatArray, d: Design, period: int, cyc: FittedModel) -> FloatArray:
    """
    Return ``r`` (scaled by ``cyc``'s phase scales) scaled by robust ones instead.

    The cycle's scales are mean squares by phase, and a few jumps of metres
    inflate the phases they fall in: the other phases' bursts then stay
    large and pair up at random, diluting the reversal test (seen on the
    cycle-and-reflections walks); medians of squares are not moved.
    """
    ph = d.phase(period)
    if cyc.cycle_scales is None:
        raise DiagnosisError('the robust cycle needs the periodic model\'s phase scales')
    raw = r * cyc.cycle_scales[ph][:, None]
    return raw / robust_phase_scales(raw, ph, period)[ph][:, None]


def run_family(split: Split, base: FittedModel, alpha: float = FAMILY_ALPHA) -> FamilyResult:
    """
    Step 3: run the first-round family on the base model's innovations.

    The mean part first: when the motion test rejects on its own (Holm's
    first step, alpha / m), the law's tests run on innovations with the lag
    removed, so that lag transients do not pass for tails or regimes.
    Likewise a cycle (or periodic variance passes for tails; the scale of
    the cycle's phases is taken out before the jumps are looked for, or its
    bursts drown them), jumps that come back (or a jump passes for a heavy
    tail; :func:`_set_jumps_aside`: when a family rejects the reversal,
    the law's tests are those with the jumps aside), and the frame
    (:func:`_family`).
    """
    _, r_law, d_law, _ = base.score(split.train, split.truth)
    motion = _motion_family(split, base, r_law)
    base_residuals = (r_law, d_law.seg)
    lag_s = None
    if motion.p_value <= alpha / N_TESTS:
        lagged = fit_model(split.train, base.orders, ('motion_lag',), split.truth)
        lag_s = lagged.mean.lag_s
        _, r_law, d_law, _ = lagged.score(split.train, split.truth)
    effects, period = ('motion_lag',) * (lag_s is not None), 0
    cycle = periodicity_test(r_law, d_law.seg, d_law.steps)
    if cycle.p_value <= alpha / N_TESTS:
        # the law's tests without the cycle, or periodic variance passes for tails
        effects, period = effects + ('periodic',), cycle.whole('at_period')
        cyc = fit_model(split.train, base.orders, effects, split.truth, lag_s, period=period)
        _, r_law, d_law, _ = cyc.score(split.train, split.truth)
    reversal = jump_reversal_test(_robust_cycle(r_law, d_law, period, cyc) if period else r_law,
                                  d_law.seg)
    jumps_in = _family(motion, (r_law, d_law, base.orders), cycle, reversal, alpha, lag_s)
    if reversal.p_value <= alpha:
        # the jumps are set aside when a family rejects the reversal: the one
        # that sees them aside (at Holm's first step, alpha / m, it always
        # does), or else the one with them in, whose rejection is then a
        # step already taken in the family aside (its law's tests on
        # innovations that still hold the jumps would find their tails and
        # their axis)
        jumpy, motion_j, lag_j = _set_jumps_aside(split, base, effects, lag_s, period, alpha)
        _, r_j, d_j, _ = jumpy.score(split.train, split.truth)
        out = _family(motion_j, (r_j, d_j, jumpy.orders), cycle, reversal, alpha, lag_j)
        if not out.reject['jump_reversal'] and jumps_in.reject['jump_reversal']:
            # the same tests, Holm again with that step taken
            given = {'jump_reversal': jumps_in.adjusted['jump_reversal']}
            out = _holm_family(out.tests, alpha, lag_j, given)
        if out.reject['jump_reversal']:
            return replace(out, base_residuals=base_residuals,
                           jump_orders=jumpy.orders if jumpy.orders != base.orders else ())
    return replace(jumps_in, base_residuals=base_residuals)


def _family(motion: Outcome, law_input: tuple[FloatArray, Design, Orders],
            cycle: Outcome, reversal: Outcome, alpha: float, lag_s: float | None
            ) -> FamilyResult:
    """
    Return the :class:`FamilyResult` of the tests on the innovations ``law_input``.

    ``law_input``: (innovations, their design, the AR orders). When the
    travel-frame test rejects on its own and axes along/across the travel
    fit better than fixed ones, the law's tests run on the innovations in
    that frame (a turning ellipse seen in fixed axes is a mixture, with the
    kurtosis of heavy tails).
    """
    r_law, d_law, orders = law_input
    frame = travel_frame_test(r_law, d_law.heading)
    r_tests = r_law
    if frame.p_value <= alpha / N_TESTS and travel_axes_win(r_law, d_law):
        r_tests = to_travel_frame(r_law, d_law.heading)
    tests = {'motion_dependence': motion,
             **innovation_tests(r_tests, d_law.seg, orders, r_law), 'travel_frame': frame,
             'periodicity': cycle, 'jump_reversal': reversal}
    return _holm_family(tests, alpha, lag_s)


def _holm_family(tests: Mapping[str, Outcome], alpha: float, lag_s: float | None,
                 given: Mapping[str, float] | None = None) -> FamilyResult:
    """Return the :class:`FamilyResult` of Holm's procedure over ``tests``."""
    decided, reject, adjusted = holm_tests(tests, alpha, given)
    return FamilyResult(tests=decided, reject=reject, adjusted=adjusted, lag_s=lag_s)


def fit_extended(split: Split, base: FittedModel, att: Attribution,
                 kept: Iterable[str] | None = None) -> FittedModel:
    """
    Step 5: the model with the effects kept (the base when none).

    ``kept``: the effects :func:`~.selection.select_effects` keeps; all the
    attributed ones when not given.
    """
    kept = tuple(att.effects) if kept is None else tuple(kept)
    if not kept:
        return base
    return fit_model(split.train, att.orders_for(kept), kept, split.truth,
                     att.lag_s if 'motion_lag' in kept else None,
                     regimes=att.regimes, period=att.period)


def retest_extended(split: Split, extended: FittedModel, att: Attribution,
                    alpha: float = RETEST_ALPHA
                    ) -> tuple[dict[str, Outcome], tuple[Any, ...]]:
    """
    Step 6: test the extended model's innovations; record what is left.

    Returns (retests, residuals): the second-round tests with Holm's
    decisions (empty without effects), and (r, seg, pred) of the training
    part. Structure left is appended to ``att.unexplained`` (nothing in the
    model targets it) or ``att.approximations`` (an effect in the model
    does, but its fitted form only approximates the data's). The serial
    tests run north/east, and only when the extended model's mean part is
    not the base's (different orders, or a lag, a cycle or jumps).
    """
    _, r, d, pred = extended.score(split.train, split.truth)
    if not extended.effects:
        return {}, (r, d.seg, pred)
    # the serial tests again only if the mean part changed: on the same
    # residuals they would test the first round's hypothesis in a smaller family
    moved = extended.orders != att.orders or any(e in extended.effects for e in MEAN_EFFECTS)
    tests = retest(extended, r, d.seg, pred,
                   from_travel_frame(r, d.heading) if 'street_frame' in extended.effects
                   else None, serial=moved)
    tests, reject, adjusted = holm_tests(tests, alpha)
    for k, t in tests.items():
        covered = tuple(e for e in RETEST_EFFECTS[k] if e in extended.effects)
        seen = any(u.structure == RETEST_LABEL[k] for u in att.unexplained)
        tests[k] = replace(t, explained_by=covered)
        if reject[k] and not covered and not seen:
            att.unexplained.append(Left(RETEST_LABEL[k], 'extended model', t.p_value,
                                        adjusted[k]))
        elif reject[k] and covered:
            att.approximations.append(Approximation(RETEST_LABEL[k], covered, adjusted[k]))
    return tests, (r, d.seg, pred)


def heldout_measures(split: Split, base: FittedModel, extended: FittedModel, sims: int, seed: int,
                     name: str) -> tuple[HeldOut, HeldOut, Improvement, int]:
    """
    Step 7: held-out NLL before and after, and the fidelity of simulations.

    Returns (error_before, error_after, improvement, scored samples).
    """
    m0 = condition_count(base.orders, extended.orders)
    ll_b = base.score(split.test, split.truth, m0)[0]
    ll_e = extended.score(split.test, split.truth, m0)[0]
    if len(ll_b) < MIN_TEST // 2:
        raise DiagnosisError(
            f'{name}: only {len(ll_b)} of {split.test.n} held-out samples can be scored '
            f'(one is when the {m0} steps before it have fixes too, and the gaps, '
            f'gross failures included, leave that few); at least {MIN_TEST // 2} are '
            f'needed')
    mean, lo, hi = block_bootstrap_mean(ll_e - ll_b, seed=seed)
    before = HeldOut(float(-ll_b.mean()), fidelity(base, split.test, split.truth, sims, seed))
    after = before if extended is base else HeldOut(
        float(-ll_e.mean()), fidelity(extended, split.test, split.truth, sims, seed))
    improvement = Improvement(
        mean, (lo, hi), 'moving-block bootstrap (blocks of 30 samples, 2000 replicates) of '
        'the paired per-sample differences NLL(before) - NLL(after); positive = better after')
    return before, after, improvement, int(len(ll_b))


@dataclass
class FittedModels:
    """Steps 1-5: the split, the base model, its tests, the extended model."""

    name: str
    split: Split
    base: FittedModel
    family: FamilyResult
    attribution: Attribution
    selection: Selection
    extended: FittedModel
    #: each recording's gross failures, left out before the split (:func:`fit_models`)
    failures: list[GrossFailures] = field(default_factory=list)


#: The stages of :func:`diagnose`, for a progress report (``done``, one call each).
STAGES = 7


def fit_models(recordings: Trace | Sequence[Trace], alpha: float = ALPHA, seed: int = 0,
               done: Callable[[], object] | None = None) -> 'FittedModels':
    """
    Run steps 1-5, ``done()`` after each of 5 stages (no held-out simulation).

    ``recordings``: a trace or a sequence of them (each keeps its segments);
    each recording's gross failures are found and left out first
    (:func:`~gps_error_ros.fit.gross_failures.without_gross_failures`), and
    the result's ``failures`` lists them.
    """
    traces, failures = without_gross_failures(recordings)
    trace = join_recordings(traces)
    return replace(fit_split(trace.name, split_step(trace), alpha, seed, done),
                   failures=failures)


#: Any value passed through :func:`_tick`.
V = TypeVar('V')


def _tick(done: Callable[[], object] | None, value: V) -> V:
    """Return ``value`` after calling ``done`` (a stage finished), if given."""
    if done is not None:
        done()
    return value


def fit_split(name: str, split: Split, alpha: float = ALPHA, seed: int = 0,
              done: Callable[[], object] | None = None) -> 'FittedModels':
    """Run steps 2-5 on a given :class:`Split`; return :class:`FittedModels`."""
    base = _tick(done, fit_base(split))
    family = _tick(done, run_family(split, base, round_levels(alpha)[0]))
    att = _tick(done, attribute(split, base, family))
    sel = _tick(done, select_effects(split, att.orders_for, att.effects, att.regimes, seed,
                                     att.period))
    extended = _tick(done, fit_extended(split, base, att, sel.kept))
    return FittedModels(name, split, base, family, att, sel, extended)


def diagnose(recordings: Trace | Sequence[Trace], sims: int = 100, seed: int = 0,
             alpha: float = ALPHA, done: Callable[[], object] | None = None) -> Diagnosis:
    """
    Run the whole procedure (``done``: after each of :data:`STAGES`); a :class:`Diagnosis`.

    ``recordings``: a trace or a sequence of them, their gross failures left
    out (:func:`fit_models`) and listed in the summary's ``gross_failures``.
    """
    fitted = fit_models(recordings, alpha, seed, done)
    split, base, family = fitted.split, fitted.base, fitted.family
    att, extended = fitted.attribution, fitted.extended
    retests, ext_residuals = _tick(done, retest_extended(split, extended, att,
                                                         round_levels(alpha)[1]))
    before, after, improvement, scored = _tick(done, heldout_measures(
        split, base, extended, sims, seed, fitted.name))
    findings = Findings(
        input=fitted.name, samples=split.train.n + split.test.n,
        train_samples=split.train.n, test_samples=split.test.n,
        scored_test_samples=scored, split_rule=split.rule, cut_time_s=split.cut_time_s,
        alpha=alpha,
        multiple_testing=f'Holm step-down in the family at alpha x {FIRST_SHARE:.4g} '
                         f'and in the retest at the rest (Bonferroni over the two)',
        estimation=ESTIMATION,
        base=ModelFound(dict(zip(AXES, base.orders)), base.parameters(), base.bic),
        tests=family.tests,
        effects=[EffectFound(e, att.evidence[e]) for e in att.effects],
        alternatives_rejected=list(att.alternatives_rejected),
        selection=fitted.selection,
        extended=ModelFound(dict(zip(AXES, extended.orders)), extended.parameters(),
                            extended.bic, retests),
        unexplained=list(att.unexplained), approximations=list(att.approximations),
        error_before=before, error_after=after, improvement=improvement,
        gross_failures=failures_doc(fitted.failures))
    return Diagnosis(findings, fitted,
                     {'base': family.base_residuals, 'extended': ext_residuals})


def extended_profile(diag: Diagnosis, name: str, source: str) -> dict[str, Any]:
    """Return the extended model as a profile mapping (schema 1, ``effects``)."""
    s = diag.findings
    return profile_mapping(
        name, f'extended model diagnosed from {source}',
        f'gps_error diagnose {source}', diag.extended.axis_params(),
        effects=diag.extended.effects_obj(),
        fit={'method': s.estimation, 'input': source,
             'train_samples': s.train_samples,
             'effects_found': s.effect_names,
             'unexplained': [u.structure for u in s.unexplained]})
