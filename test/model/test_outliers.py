"""The outliers effect: the reported fix jumps away for a few fixes, and back."""

import numpy as np
import pytest
import yaml

from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import AxisParams
from gps_error_ros.model.effects import build_model, effects_from_dict, EffectsError
from gps_error_ros.model.profiles import load_profile, builtin_dir, load_profile_file

SECTION = {'rate': 0.02, 'mean_steps': 2.5, 'sigma_m': 8.0}
NORTH, EAST = AxisParams(0.3, (0.9,), 0.8), AxisParams(-0.2, (1.1, -0.2), 0.6)


def model(**more):
    return build_model(NORTH, EAST, effects_from_dict({'outliers': SECTION, **more}))


def keys(n, seed=1):
    return streams.agent_keys(seed, [f'a{i}' for i in range(n)])


def test_simulated_autocovariance_is_the_exact_one():
    m = model()
    x = m.simulate(keys(400), 2500)
    d = x - m.mean
    exact = m.autocovariance(6)
    assert exact[0, 0, 0] > 1.5 * build_model(NORTH, EAST).autocovariance(0)[0, 0, 0]
    for k in (0, 1, 3, 6):
        emp = np.einsum('tni,tnj->ij', d[k:], d[:len(d) - k]) / (d[k:].shape[0] * d.shape[1])
        np.testing.assert_allclose(emp, exact[k], atol=0.04 * exact[0].max())


def test_jumps_have_the_rate_and_length_and_leave_the_ar_part_alone():
    m = model()
    k = keys(300)
    with_jumps = m.simulate(k, 3000)
    plain = build_model(NORTH, EAST).simulate(k, 3000)
    off = with_jumps - plain        # the same innovations: only the jumps differ
    inside = np.any(np.abs(off) > 1e-6, axis=2)       # (steps, agents)
    starts = inside[1:] & ~inside[:-1]
    clean_steps = (~inside[:-1]).sum()
    assert starts.sum() / clean_steps == pytest.approx(SECTION['rate'], rel=0.06)
    lengths = inside.sum() / max(1, starts.sum() + inside[0].sum())
    assert lengths == pytest.approx(SECTION['mean_steps'], rel=0.06)
    # an offset holds while its jump lasts, and is N(0, sigma^2) per axis
    held = inside[1:] & inside[:-1]
    np.testing.assert_allclose(off[1:][held], off[:-1][held], atol=1e-6)
    first = off[1:][starts]
    assert np.std(first, axis=0) == pytest.approx([8.0, 8.0], rel=0.06)
    assert abs(np.corrcoef(first.T)[0, 1]) < 0.06


def test_state_is_pure_in_the_agents_stream():
    m = model()
    k = keys(64, seed=3)
    state = m.initial_state(k, 5)
    for step in range(6, 200):
        m.advance(state, k, step)
    assert m.state_after(k, 5, 199).same_as(state)
    alone = m.state_after(k[9:10], 5, 199)
    assert alone.same_as(state.take([9]))
    assert all(np.isfinite(v).all() for v in state.arrays().values())


def test_predictive_covariance_adds_the_next_offsets():
    """Against the draws: the covariance of the next error given the state."""
    m = model()
    k = keys(2)
    state = m.initial_state(k, 0)
    for step in range(1, 40):
        m.advance(state, k, step)
    # one agent in a jump, one clean, then the next step drawn 200,000 ways each
    state.jump[0], state.in_jump[0] = (5.0, -3.0), 1.0
    state.jump[1], state.in_jump[1] = 0.0, 0.0
    cov = m.predictive_cov(state)
    many = state.take(np.repeat(np.arange(2), 200000))
    draws = keys(400000, seed=9)
    nxt = m.advance(many, draws, 41)
    for agent in range(2):
        got = np.cov(nxt[agent * 200000:(agent + 1) * 200000].T)
        np.testing.assert_allclose(got, cov[agent], atol=0.05 * cov[agent].max() + 0.02)
    q = 1 / SECTION['mean_steps']
    assert cov[0, 0, 1] == pytest.approx(q * (1 - q) * 5.0 * -3.0 + m.unit.innovation_cov[0, 1])


@pytest.mark.parametrize('change, hint', [
    ({'rate': 0.0}, 'rate'),
    ({'rate': 0.7}, 'rate'),
    ({'mean_steps': 0.5}, 'mean_steps'),
    ({'sigma_m': float('nan')}, 'sigma_m'),
])
def test_bad_sections_are_named(change, hint):
    with pytest.raises(EffectsError) as err:
        effects_from_dict({'outliers': {**SECTION, **change}}, 'p.yaml')
    assert 'p.yaml' in str(err.value) and f'effects.outliers.{hint}' in str(err.value)


def test_profile_round_trip_and_zones_carry_it(tmp_path):
    raw = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    raw['effects'] = {'outliers': SECTION, 'heavy_tails': {'dof': 6.0}}
    path = tmp_path / 'jumps.yaml'
    path.write_text(yaml.safe_dump(raw))
    p = load_profile_file(path)
    assert p.effects.to_dict()['outliers'] == SECTION
    assert p.effects.names == ('heavy_tails', 'outliers')
    # in a zone map: an agent that stays in the jumps' zone has the profile's own errors
    from gps_error_ros.model.stepping import StepsPerFix
    from gps_error_ros.model.zoned import simulate_along, WithZones
    keys = streams.agent_keys(2, [f'z{i}' for i in range(50)])
    zones = WithZones([p.process(), load_profile('DS1').process()])
    stay = simulate_along(StepsPerFix(zones), keys, np.arange(400), np.zeros(400, int))
    np.testing.assert_allclose(stay, p.model().simulate(keys, 400), atol=1e-9)
    # one that enters it draws a jump under way from its stationary law, and jumps there
    enter = simulate_along(StepsPerFix(zones), keys, np.arange(400),
                           np.r_[np.full(100, -1), np.zeros(300, int)])
    np.testing.assert_allclose(enter[:100], load_profile('DS1').model().simulate(keys, 100),
                               atol=1e-9)
    assert np.all(np.isfinite(enter))
    share = np.mean(np.hypot(*(enter[200:] - stay[200:]).T) > 0)
    assert share > 0.5          # the AR part, carried from DS1, has not yet forgotten it
