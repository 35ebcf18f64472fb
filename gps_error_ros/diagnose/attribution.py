"""
Step 4 of the diagnosis: from the rejected tests to effects, or ``unexplained``.

A rejected test names the effect that explains it (motion, coupling, the
travel frame, a cycle, jumps that come back); where two effects explain the same test (tails or
regimes; a fixed or a turning ellipse) the training BIC decides between
them. What no effect explains is reported as ``unexplained``, never forced
into an effect.
"""

from collections.abc import Collection
from dataclasses import dataclass, field
import math
from typing import Optional

import numpy as np

from gps_error_ros.diagnose.common import EFFECT_ORDER
from gps_error_ros.diagnose.laws import fit_law, law_logpdf
from gps_error_ros.diagnose.family import FamilyResult
from gps_error_ros.diagnose.findings import Alternative, Approximation, Json, Left
from gps_error_ros.diagnose.mean import Design, to_travel_frame
from gps_error_ros.diagnose.models import fit_model, FittedModel
from gps_error_ros.fit.holdout import Split
from gps_error_ros.model.ar_model import AXES
from gps_error_ros.model.state import FloatArray


@dataclass
class Attribution:
    """Effects chosen from the tests, with their evidence, and what is left."""

    effects: list[str]
    evidence: dict[str, dict[str, Json]]       # by effect: its test, figures, BICs
    alternatives_rejected: list[Alternative]
    unexplained: list[Left]
    regimes: int = 2
    lag_s: Optional[float] = None
    period: int = 0             # periodic: the cycle's length, steps
    orders: tuple[int, ...] = ()          # the base model's AR orders
    # with outliers: those of the series without its jumps
    jump_orders: tuple[int, ...] = ()
    approximations: list[Approximation] = field(default_factory=list)

    def orders_for(self, effects: Collection[str]) -> tuple[int, ...]:
        """Return the AR orders of a model with ``effects``."""
        return self.jump_orders if 'outliers' in effects and self.jump_orders else self.orders


def travel_axes_win(r: FloatArray, d: Design) -> bool:
    """Return True when a Gaussian law along/across the travel beats fixed axes (BIC)."""
    n = len(r)
    bic = {}
    for name, x, coupled in (('fixed', r, True),
                             ('travel', to_travel_frame(r, d.heading), False)):
        law = fit_law(x, d.seg, coupled=coupled)
        bic[name] = -2 * float(np.sum(law_logpdf(law, x, d.seg)[0])) + \
            law.n_params * math.log(n)
    return bic['travel'] < bic['fixed']


def _attribute_law(split: Split, base: FittedModel, family: FamilyResult,
                   att: Attribution) -> None:
    """Tails against regimes: add the winner to ``att`` (training BIC)."""
    tests, reject, adjusted = family.tests, family.reject, family.adjusted
    train, truth, orders = split.train, split.truth, att.orders_for(att.effects)
    common = tuple(att.effects)
    cands = {'heavy_tails': (('heavy_tails',), 2),
             'variance_regimes (2 levels)': (('variance_regimes',), 2),
             'variance_regimes (3 levels)': (('variance_regimes',), 3),
             'both (2 levels + tails)': (('heavy_tails', 'variance_regimes'), 2)}
    bics = {'neither': fit_model(train, orders, common, truth, att.lag_s).bic}
    for label, (extra, k) in cands.items():
        bics[label] = fit_model(train, orders, common + extra, truth,
                                att.lag_s, regimes=k).bic
    if reject['squared_persistence']:
        pick = min([c for c in cands if c != 'heavy_tails'], key=lambda k: bics[k])
        extra, att.regimes = cands[pick]
        att.effects.extend(e for e in EFFECT_ORDER if e in extra)
        att.evidence['variance_regimes'] = {
            'test': 'squared_persistence', **tests['squared_persistence'].picked(),
            'levels': att.regimes, 'bic': bics, 'chosen': pick}
        if 'heavy_tails' in extra:
            att.evidence['heavy_tails'] = {
                'test': 'kurtosis and BIC', **tests['kurtosis'].picked(),
                'reason': 'tails beyond the regimes: the BIC with both is '
                          'the lowest', 'bic': bics}
        else:
            att.alternatives_rejected.append(Alternative(
                'heavy_tails', 'with the regimes, Student-t innovations do not lower the BIC '
                '(the marginal tails come from the regimes)', bics))
        return
    att.effects.append('heavy_tails')
    att.evidence['heavy_tails'] = {
        'test': 'kurtosis', **tests['kurtosis'].picked(), 'bic': bics,
        'reason': 'excess kurtosis without persistence of the squared '
                  'innovations'}
    att.alternatives_rejected.append(Alternative(
        'variance_regimes', 'the squared innovations do not persist (Holm-adjusted '
        f'p = {adjusted["squared_persistence"]:.3g})', bics))


def _attribute_cycle(split: Split, base: FittedModel, family: FamilyResult,
                     att: Attribution) -> None:
    """
    Add ``periodic`` to ``att``: the test's period, or a divisor (training BIC).

    A cycle of P steps is also one of every multiple of P, and the test
    picks whichever stands out most; the period kept is the divisor of its
    P (itself included) whose model has the lowest training BIC.
    """
    t = family.tests['periodicity']
    common = tuple(att.effects)
    bics = {p: fit_model(split.train, att.orders_for(common), common + ('periodic',),
                         split.truth,
                         att.lag_s, att.regimes, period=p).bic
            for p in range(2, t.whole('at_period') + 1) if t.whole('at_period') % p == 0}
    att.period = min(bics, key=lambda k: bics[k])
    att.effects.append('periodic')
    att.evidence['periodic'] = {'test': 'periodicity', **t.picked(), 'in': t.word('in'),
                                'period_steps': att.period,
                                'bic_by_period': {str(k): v for k, v in bics.items()}}


def _attribute_frame(split: Split, base: FittedModel, family: FamilyResult,
                     att: Attribution) -> None:
    """
    Axes fixed north/east (coupling) against axes of the travel: training BIC.

    The travel-frame test rejected: the innovation covariance depends on the
    direction of travel. A fixed ellipse that only changes its elongation
    with the direction can do that too, so the law with the fixed, coupled
    covariance and the law along/across the travel are both fitted, and the
    lower BIC decides.
    """
    common = tuple(e for e in att.effects if e != 'cross_axis_coupling')
    bics = {name: fit_model(split.train, att.orders_for(common), common + (name,), split.truth,
                            att.lag_s).bic
            for name in ('cross_axis_coupling', 'street_frame')}
    pick = min(bics, key=lambda k: bics[k])
    other = 'street_frame' if pick == 'cross_axis_coupling' else 'cross_axis_coupling'
    t = family.tests['travel_frame']
    att.effects[:] = [e for e in EFFECT_ORDER if e in common + (pick,)]
    att.evidence.pop(other, None)
    att.evidence.setdefault(pick, {'test': 'travel_frame', **t.picked()})
    att.evidence[pick]['frame_bic'] = bics
    att.alternatives_rejected.append(Alternative(
        other, ('the covariance turns with the direction of travel, but a fixed '
                'north/east ellipse fits it better (lower BIC)') if other == 'street_frame'
        else ('the innovation covariance turns with the direction of travel: axes along '
              'and across it fit better than fixed north/east axes (lower BIC)'), bics))


def attribute(split: Split, base: FittedModel, family: FamilyResult) -> Attribution:
    """Step 4: turn the rejected tests into effects, or ``unexplained``."""
    tests, reject, adjusted = family.tests, family.reject, family.adjusted
    att = Attribution([], {}, [], [], orders=base.orders, jump_orders=family.jump_orders)
    for test, effect in (('cross_axis_correlation', 'cross_axis_coupling'),
                         ('motion_dependence', 'motion_lag')):
        if reject[test]:
            att.effects.append(effect)
            att.evidence[effect] = {'test': test, **tests[test].picked()}
    att.lag_s = family.lag_s if 'motion_lag' in att.effects else None
    if reject['jump_reversal']:
        att.effects.append('outliers')
        t = tests['jump_reversal']
        att.evidence['outliers'] = {'test': 'jump_reversal', **t.picked(),
                                    'pairs': t.whole('pairs'), 'large': t.whole('large')}
    if reject['travel_frame']:
        _attribute_frame(split, base, family, att)
    if reject['squared_persistence'] or reject['kurtosis']:
        _attribute_law(split, base, family, att)
    if reject['periodicity']:
        _attribute_cycle(split, base, family, att)
    if reject['squared_oscillation'] and 'periodic' not in att.effects:
        t = tests['squared_oscillation']
        att.unexplained.append(Left(
            'periodic variance: squared innovations anti-correlated at lag '
            f'{t.whole("at_lag")}', 'base model', t.p_value, adjusted['squared_oscillation']))
    for ax in AXES:
        k = f'serial_{ax}'
        if reject[k]:
            att.unexplained.append(Left(
                RETEST_LABEL[k], 'base model', tests[k].p_value, adjusted[k],
                tuple(tests[k].wholes('largest_acf_lags'))))
    att.effects[:] = [e for e in EFFECT_ORDER if e in att.effects]
    return att


RETEST_LABEL = {
    'cross_axis_correlation': 'north-east correlation left in the innovations',
    'squared_persistence': 'persistence of the squared innovations left',
    'pit_uniformity': 'predictive distribution miscalibrated (PIT of the radius)',
    'serial_north': 'serial correlation of the north innovations',
    'serial_east': 'serial correlation of the east innovations',
}

#: retest -> effects whose fitted form targets that structure
RETEST_EFFECTS = {
    'cross_axis_correlation': ('cross_axis_coupling', 'street_frame'),
    'squared_persistence': ('variance_regimes',),
    'pit_uniformity': ('heavy_tails', 'variance_regimes', 'outliers'),
    'serial_north': (),
    'serial_east': (),
}
