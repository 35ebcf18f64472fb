"""The named state: what every state class gives those who hold a state without its fields."""

import numpy as np
import pytest
import yaml

from gps_error_ros.model import streams
from gps_error_ros.model.profiles import builtin_dir, profile_from_dict
from gps_error_ros.model.state import ARState

SECTIONS = {
    'effects': {'variance_regimes': {'scales': [1.0, 2.0],
                                     'transition': [[0.9, 0.1], [0.2, 0.8]]},
                'outliers': {'rate': 0.05, 'mean_steps': 2.0, 'sigma_m': 5.0}},
    'population': {'bias_sd_m': [2.0, 3.0], 'scale_sd_log': 0.3,
                   'run_bias_sd_m': [1.0, 1.5]},
    'gross_failures': {'rate': 0.05, 'sizes_m': [300.0]},
    'availability': {'outage_rate': 0.05, 'durations': [[3, 1.0]]},
}


def _model():
    raw = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    raw.update(SECTIONS)
    return profile_from_dict(raw, 'every wrapper').model(about_truth=True)


def test_a_wrapped_state_names_every_part():
    state = _model().initial_state(streams.agent_keys(1, ['a', 'b']), 0)
    assert sorted(state.arrays()) == sorted([
        'outage_left', 'inner.offset', 'inner.inner.bias', 'inner.inner.scale',
        'inner.inner.bias_factor', 'inner.inner.held', 'inner.inner.inner.deviations',
        'inner.inner.inner.regime', 'inner.inner.inner.heading', 'inner.inner.inner.phase',
        'inner.inner.inner.cycle_offset', 'inner.inner.inner.jump',
        'inner.inner.inner.in_jump'])
    assert all(len(v) == 2 for v in state.arrays().values())


def test_take_put_and_join_move_agents_whole():
    model = _model()
    keys = streams.agent_keys(1, [f'a{i}' for i in range(6)])
    state = model.state_after(keys, 0, 40)
    # agents stepped in any grouping are the same agents
    parts = state.take([0, 1, 2]).joined(state.take(np.array([3, 4, 5])))
    assert parts.same_as(state)
    model.advance(parts, keys, 41)
    alone = state.take([4])
    model.advance(alone, keys[4:5], 41)
    assert alone.same_as(parts.take([4]))
    # put writes rows, take copies
    blank = model.empty_state(6)
    blank.put([5, 0], state.take([0, 5]))
    assert blank.take([5]).same_as(state.take([0]))
    copy = state.take([1])
    model.advance(copy, keys[1:2], 41)
    assert not copy.same_as(state.take([1]))
    assert len(state) == 6 and len(model.empty_state(0)) == 0


def test_states_of_different_models_do_not_mix():
    model = _model()
    state = model.empty_state(2)
    with pytest.raises(TypeError, match='cannot put a ARState'):
        state.put([0], ARState(np.zeros((1, 2, 3))))
    assert not state.same_as(ARState(np.zeros((2, 2, 3))))
