"""The registry of effects: each effect one kind, read by the schema, the step and the docs."""

from pathlib import Path

import numpy as np
import pytest
import yaml

from gps_error_ros.diagnose.common import EFFECT_ORDER
from gps_error_ros.model.ar_model import AxisParams
from gps_error_ros.model.effect_kind import Term
from gps_error_ros.model.effect_kinds import BY_NAME, EFFECT_NAMES, KINDS, markdown_table
from gps_error_ros.model.effects import effects_from_dict, EffectsError, ExtendedModel
from gps_error_ros.model.streams import agent_keys

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = yaml.safe_load('''
cross_axis_coupling: {innovation_corr: 0.35}
motion_lag: {lag_s: 1.2}
heavy_tails: {dof: 4.5}
variance_regimes: {scales: [1.0, 2.4], transition: [[0.98, 0.02], [0.05, 0.95]]}
street_frame: {sigma_along: 0.6, sigma_across: 1.4}
periodic: {period_steps: 4, scales: [1.6, 0.7, 0.9, 0.8],
           offsets: [[0.3, -0.1], [-0.2, 0.1], [0.0, 0.0], [-0.1, 0.0]]}
outliers: {rate: 0.01, mean_steps: 2.0, sigma_m: 12.0}
''')
NORTH = AxisParams(0.1, (0.9, -0.1), 1.0)
EAST = AxisParams(-0.2, (0.8,), 1.2)


def test_the_registry_is_the_schemas_and_the_diagnosis_order():
    assert EFFECT_NAMES == tuple(k.name for k in KINDS) == EFFECT_ORDER
    built_in = ('cross_axis_coupling', 'motion_lag', 'heavy_tails', 'variance_regimes',
                'street_frame', 'periodic', 'outliers')
    assert tuple(n for n in EFFECT_NAMES if n in built_in) == built_in
    assert [k.order for k in KINDS] == sorted(k.order for k in KINDS)
    assert BY_NAME['street_frame'].sets_innovations


@pytest.mark.parametrize('name', sorted(EXAMPLE))
def test_each_kind_reads_and_writes_its_section(name):
    others = {k: v for k, v in EXAMPLE.items() if k != 'street_frame' or name == k}
    if name == 'street_frame':
        others.pop('cross_axis_coupling')
    effects = effects_from_dict(others)
    assert name in effects and effects.names == tuple(n for n in EFFECT_NAMES if n in others)
    assert effects_from_dict(effects.to_dict()) == effects
    bad = dict(others, **{name: dict(EXAMPLE[name], surplus=1)})
    with pytest.raises(EffectsError, match=f'effects.{name}.*expected a mapping with exactly'):
        effects_from_dict(bad)


def test_one_effect_sets_the_innovations():
    with pytest.raises(EffectsError, match='street_frame and cross_axis_coupling both set'):
        effects_from_dict(EXAMPLE)
    with pytest.raises(EffectsError, match="unknown effect; expected one of"):
        effects_from_dict({'drift': {'rate': 1}})


def test_the_model_calls_only_the_hooks_a_term_overrides():
    effects = effects_from_dict({k: v for k, v in EXAMPLE.items()
                                 if k != 'cross_axis_coupling'})
    model = ExtendedModel(NORTH, EAST, effects)
    kinds = [BY_NAME[n] for n in effects.names]
    stages = sorted((k.stage, k.order) for k in kinds
                    if k.term(effects[k.name], model.phi, model.order) is not None)
    assert [(BY_NAME[_name(t)].stage, BY_NAME[_name(t)].order) for t in model.terms] == stages
    assert model.needs_heading and model._innovator is not None
    for t in model._shapers:
        assert type(t).shape is not Term.shape
    keys = agent_keys(1, ['a', 'b'])
    out = model.simulate(keys, 50)
    assert np.isfinite(out).all() and out.shape == (50, 2, 2)


def _name(term):
    """Return the name of the kind a term belongs to (its module's KIND)."""
    import sys
    return sys.modules[type(term).__module__].KIND.name


def test_the_docs_table_is_the_registrys():
    page = (ROOT / 'docs' / 'effects.md').read_text()
    start = page.index('<!-- effects:table -->\n') + len('<!-- effects:table -->\n')
    assert page[start:page.index('<!-- /effects:table -->')] == markdown_table(), \
        'docs/effects.md: the table of effects is stale: run python tools/readme_parameters.py'
