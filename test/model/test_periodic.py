"""The periodic effect: a cycle in the innovations' variance and mean."""

import numpy as np
import pytest
import yaml

from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import AxisParams
from gps_error_ros.model.effects import build_model, effects_from_dict, EffectsError
from gps_error_ros.model.periodic import periodic_mean
from gps_error_ros.model.profiles import builtin_dir, load_profile_file

PERIOD = 8
SCALES = [1.6, 0.7, 0.7, 0.7, 1.6, 0.7, 0.7, 0.7]
RAW_OFFSETS = np.array([[0.6, -0.3], [-0.2, 0.1], [0.0, 0.0], [-0.4, 0.2]] * 2)
OFFSETS = (RAW_OFFSETS - RAW_OFFSETS.mean(axis=0)).tolist()
SECTION = {'period_steps': PERIOD, 'scales': SCALES, 'offsets': OFFSETS}
NORTH, EAST = AxisParams(0.1, (0.8,), 0.5), AxisParams(0.0, (1.2, -0.3), 0.4)


def model(**more):
    return build_model(NORTH, EAST, effects_from_dict({'periodic': SECTION, **more}))


def test_simulated_autocovariance_is_the_exact_one():
    m = model()
    x = m.simulate(streams.agent_keys(1, [f'a{i}' for i in range(400)]), 2000)
    d = x - m.mean
    exact = m.autocovariance(8)
    for k in (0, 1, 4, 8):
        emp = np.einsum('tni,tnj->ij', d[k:], d[:len(d) - k]) / (d[k:].shape[0] * d.shape[1])
        np.testing.assert_allclose(emp, exact[k], atol=0.03 * exact[0].max())
    # the cycle's mean shows at the period: north's AR(1) alone decays at
    # every lag; with the cycle the autocovariance rises again at lag 8
    assert np.all(np.diff(build_model(NORTH, EAST).autocovariance(8)[:, 0, 0]) < 0)
    assert exact[8, 0, 0] > 1.3 * exact[7, 0, 0]


def test_phases_are_per_agent_and_pure():
    m = model()
    keys = streams.agent_keys(3, [f'a{i}' for i in range(64)])
    state = m.initial_state(keys, 5)
    offsets = state.cycle_offset
    assert len(set(offsets.astype(int))) >= 6            # phones are not in step
    for k in range(6, 30):
        m.advance(state, keys, k)
    again = m.state_after(keys, 5, 29)
    assert again.same_as(state)
    assert np.all(state.phase == (offsets + 29) % PERIOD)
    alone = m.state_after(keys[7:8], 5, 29)                # not how many agents run together
    assert alone.same_as(state.take([7]))


def test_steady_state_mean_solves_the_recursion():
    phi = np.array([[0.8, 0.0], [1.2, -0.3]])
    m = periodic_mean(phi, OFFSETS)
    for j in range(PERIOD):
        for a in range(2):
            want = phi[a, 0] * m[j - 1, a] + phi[a, 1] * m[j - 2, a] + OFFSETS[j][a]
            assert m[j, a] == pytest.approx(want, abs=1e-12)


def test_predictive_covariance_follows_the_phase():
    m = model()
    keys = streams.agent_keys(2, ['x', 'y'])
    state = m.initial_state(keys, 0)
    for k in range(1, 20):
        cov = m.predictive_cov(state)
        nxt = (state.phase + 1) % PERIOD
        want = m.unit.innovation_cov[None] * (np.array(SCALES)[nxt] ** 2)[:, None, None]
        np.testing.assert_allclose(cov, want, rtol=1e-12)
        m.advance(state, keys, k)


@pytest.mark.parametrize('change, hint', [
    ({'period_steps': 1}, 'period_steps'),
    ({'scales': SCALES[:-1]}, 'list of 8 positive numbers'),
    ({'offsets': [[1.0, 0.0]] * PERIOD}, 'averaging 0 per axis'),
    ({'scales': SCALES[:-1] + [-1.0]}, 'periodic.scales: expected a non-empty list of numbers'),
    ({'offsets': [[0.0, 0.0, 0.0]] * PERIOD}, '[north, east] pairs of numbers in [-10000, 10000]'),
])
def test_bad_sections_are_named(change, hint):
    with pytest.raises(EffectsError) as err:
        effects_from_dict({'periodic': {**SECTION, **change}}, 'p.yaml')
    assert 'p.yaml' in str(err.value) and hint in str(err.value)


def test_profile_round_trip(tmp_path):
    raw = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    raw['effects'] = {'periodic': SECTION, 'heavy_tails': {'dof': 6.0}}
    path = tmp_path / 'cyc.yaml'
    path.write_text(yaml.safe_dump(raw))
    p = load_profile_file(path)
    assert p.effects.to_dict()['periodic'] == {
        'period_steps': PERIOD, 'scales': SCALES,
        'offsets': [[round(a, 6), round(b, 6)] for a, b in OFFSETS]}
    assert 'periodic' in p.effects.names
