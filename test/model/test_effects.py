"""Profiles with an ``effects`` section: schema, simulation, covariance, lag."""

import math

import numpy as np
import pytest

from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import ARErrorModel, AxisParams
from gps_error_ros.sim.simulate import simulate_csv
from gps_error_ros.sim.crowd import CrowdErrors
from gps_error_ros.model.effects import (Effects, effects_from_dict, EffectsError,
                                         ExtendedModel)
from gps_error_ros.model.motion_lag import held_across_gaps, lag_offsets, LagBuffer
from gps_error_ros.sim.engine import FixEngine, NS
from gps_error_ros.model.geodesy import difference, offset
from gps_error_ros.model.profiles import load_profile, ProfileError

NORTH = AxisParams(0.1, (0.9, -0.1), 1.0)
EAST = AxisParams(-0.05, (0.7,), 0.8)
ALL = {'cross_axis_coupling': {'innovation_corr': 0.4},
       'motion_lag': {'lag_s': 2.0},
       'heavy_tails': {'dof': 5.0},
       'variance_regimes': {'scales': [1.0, 2.5],
                            'transition': [[0.97, 0.03], [0.06, 0.94]]}}

PROFILE = """schema: 1
name: EXT
description: test
source: test
rate_hz: 1.0
axes:
  north: {delta: 0.1, phi: [0.9, -0.1], sigma_w: 1.0}
  east:  {delta: -0.05, phi: [0.7], sigma_w: 0.8}
"""


def test_effects_round_trip_and_names():
    eff = effects_from_dict(ALL)
    assert eff.names == ('cross_axis_coupling', 'motion_lag', 'heavy_tails',
                         'variance_regimes')
    assert effects_from_dict(eff.to_dict()) == eff
    assert effects_from_dict({}) == Effects()
    assert Effects().names == ()
    pi = eff.regime_probabilities
    assert pi == pytest.approx([2 / 3, 1 / 3])
    assert eff.variance_factor == pytest.approx(2 / 3 + 6.25 / 3)


@pytest.mark.parametrize('raw, key', [
    ({'colour': {}}, 'effects.colour'),
    ({'heavy_tails': {'dof': 2.0}}, 'effects.heavy_tails.dof'),
    ({'heavy_tails': {'nu': 4}}, 'effects.heavy_tails'),
    ({'motion_lag': {'lag_s': 11}}, 'effects.motion_lag.lag_s'),
    ({'cross_axis_coupling': {'innovation_corr': 1.0}},
     'effects.cross_axis_coupling.innovation_corr'),
    ({'variance_regimes': {'scales': [1.0], 'transition': [[1.0]]}},
     'effects.variance_regimes.scales'),
    ({'variance_regimes': {'scales': [1, 2], 'transition': [[0.9, 0.2], [0.1, 0.9]]}},
     'effects.variance_regimes.transition[0]'),
    ({'variance_regimes': {'scales': [1, 2], 'transition': [[1.0]]}},
     'effects.variance_regimes.transition'),
])
def test_invalid_effects_name_the_key(raw, key):
    with pytest.raises(EffectsError) as exc:
        effects_from_dict(raw, 'p.yaml')
    assert 'p.yaml' in str(exc.value) and key in str(exc.value)


def test_profile_with_effects_loads_and_without_is_unchanged(tmp_path):
    f = tmp_path / 'ext.yaml'
    f.write_text(PROFILE + 'effects:\n  heavy_tails: {dof: 4.0}\n'
                 '  cross_axis_coupling: {innovation_corr: -0.3}\n')
    model = load_profile(str(f)).model()
    assert isinstance(model, ExtendedModel)
    assert model.stationary_cov[0, 1] < 0
    plain = tmp_path / 'plain.yaml'
    plain.write_text(PROFILE)
    m0 = load_profile(str(plain)).model()
    assert type(m0) is ARErrorModel
    ref = ARErrorModel(NORTH, EAST)
    keys = streams.agent_keys(3, ['a', 'b'])
    assert np.array_equal(m0.simulate(keys, 50), ref.simulate(keys, 50))
    bad = tmp_path / 'bad.yaml'
    bad.write_text(PROFILE + 'effects:\n  heavy_tails: {dof: 1.5}\n')
    with pytest.raises(ProfileError) as exc:
        load_profile(str(bad))
    assert str(bad) in str(exc.value) and 'effects.heavy_tails.dof' in str(exc.value)


def test_long_runs_match_the_published_covariance():
    """200 agents x 4000 steps with every effect: the unconditional covariance."""
    model = ExtendedModel(NORTH, EAST, effects_from_dict(ALL))
    keys = streams.agent_keys(11, [f'a{i}' for i in range(200)])
    x = model.simulate(keys, 4000)[500:]                    # (T, agents, 2)
    d = x - model.mean
    per_agent = np.einsum('tai,taj->aij', d, d) / d.shape[0]   # (agents, 2, 2)
    est = per_agent.mean(axis=0)
    se = per_agent.std(axis=0, ddof=1) / math.sqrt(per_agent.shape[0])
    cov = model.stationary_cov
    assert np.all(np.abs(est - cov) < 5 * se), (est, cov, se)
    # the innovations: heavy tails and persistent variance, correlated axes
    w = d[1:, :, 0] - 0.9 * d[:-1, :, 0] + 0.1 * np.r_[d[:1, :, 0], d[:-2, :, 0]]
    w = w[5:]
    # their law, exactly: E[w^2] / E|w|^2 of a Gaussian scaled by the regime
    # and by the Student-t mixing variable g (E g^2 = 1), pi/2 for a Gaussian
    nu, pi, sc = 5.0, model.effects.regime_probabilities, np.asarray(model.effects.scales)
    e_g = math.sqrt(nu - 2) * math.gamma((nu - 1) / 2) / (math.sqrt(2) * math.gamma(nu / 2))
    want = (pi @ sc ** 2) / ((pi @ sc) ** 2 * e_g ** 2 * 2 / math.pi)
    ratio = np.mean(w ** 2, axis=0) / np.mean(np.abs(w), axis=0) ** 2     # per agent
    se = ratio.std(ddof=1) / math.sqrt(ratio.size)
    assert abs(ratio.mean() - want) < 5 * se, (ratio.mean(), want, se)
    assert want > math.pi / 2 + 20 * se          # the test tells it from a Gaussian
    v = np.abs(w[5:]) ** 2
    lag1 = np.mean([np.corrcoef(v[:-1, a], v[1:, a])[0, 1] for a in range(200)])
    assert lag1 > 0.05


def test_gaussian_extended_equals_plain_with_correlation_only():
    eff = Effects({'cross_axis_coupling': 0.3})
    ext = ExtendedModel(NORTH, EAST, eff)
    ref = ARErrorModel(NORTH, EAST, 0.3)
    keys = streams.agent_keys(5, ['x', 'y', 'z'])
    assert np.allclose(ext.simulate(keys, 300), ref.simulate(keys, 300),
                       rtol=0, atol=1e-9)
    assert np.allclose(ext.stationary_cov, ref.stationary_cov)


def test_agent_errors_do_not_depend_on_the_crowd_or_catch_up():
    model = ExtendedModel(NORTH, EAST, effects_from_dict(ALL))
    names = [f'p{i}' for i in range(40)]
    keys = streams.agent_keys(2, names)
    crowd = model.simulate(keys, 120, start=7)
    alone = model.simulate(keys[5:6], 120, start=7)
    assert np.array_equal(crowd[:, 5], alone[:, 0])
    late = CrowdErrors(model, 2, 7)
    late.advance_to(7 + 60)
    assert np.array_equal(late.errors(['p5'])[0], crowd[60, 5])


def test_engine_reports_the_truth_lag_s_earlier():
    """A walker at 1.5 m/s east: fix = truth(t - 2 s) + AR error, exactly."""
    model = ExtendedModel(NORTH, EAST, Effects({'motion_lag': 2.0}))
    keys = streams.agent_keys(4, [''])
    eng = FixEngine(model, keys, max_pose_age=1.0)
    lat0, lon0 = 40.75, -73.99
    fixes = []
    for k in range(100, 140):
        for sub in range(10):                    # truth at 10 Hz
            t = k + sub / 10
            lat, lon = offset(lat0, lon0, 0.0, 1.5 * (t - 100))
            eng.add_truth(0, int(round(t * NS)), float(lat), float(lon), 0.0)
        fixes += eng.on_clock(k * NS)
    assert len(fixes) >= 35
    ref = model.simulate(keys, 40, start=100)[:, 0]
    for f in fixes:
        k = f.stamp_ns // NS
        n, e = difference(f.lat[0], f.lon[0], lat0, lon0)
        assert n == pytest.approx(ref[k - 100, 0], abs=1e-4)
        assert e - 1.5 * (k - 2 - 100) == pytest.approx(ref[k - 100, 1], abs=1e-4)


def test_lag_helpers():
    t = np.arange(10.0)
    off = lag_offsets(t, np.zeros(10), 2.0 * t, 1.5)
    assert off[5:, 1] == pytest.approx(-3.0)
    assert off[0, 1] == 0.0
    # two runs 100 s apart, 20 km from each other: a lag reaches back within a run,
    # and at the later run's start holds its first position, not the gap's blend
    t2 = np.r_[t, 109.0 + t]
    east = np.r_[2.0 * t, 20000.0 + 2.0 * t]
    off = lag_offsets(t2, np.zeros(20), east, 1.5, gap_s=60.0)
    assert off[10, 1] == 0.0 and off[15:, 1] == pytest.approx(-3.0)
    assert lag_offsets(t2, np.zeros(20), east, 1.5)[10, 1] < -250.0     # bridged: 20 km / 100 s
    assert held_across_gaps(t2, [5.5, 50.0, 108.9, 109.0, 110.5], 60.0) == \
        pytest.approx([5.5, 109.0, 109.0, 109.0, 110.5])
    assert held_across_gaps(t2, [50.0], None) == pytest.approx([50.0])
    buf = LagBuffer(1.5)
    out = [buf.lagged(['a'], float(k), [2.0 * k], [0.0])[0][0] for k in range(6)]
    assert out[:2] == [0.0, 0.0]
    assert out[3:] == pytest.approx([3.0, 5.0, 7.0])


def test_simulate_csv_applies_the_lag(tmp_path):
    src = tmp_path / 'truth.csv'
    lat0, lon0 = 40.75, -73.99
    rows = ['t,agent,truth_lat,truth_lon']
    for k in range(30):
        lat, lon = offset(lat0, lon0, 1.0 * k, 0.0)
        rows.append(f'{k},w,{float(lat)!r},{float(lon)!r}')
    src.write_text('\n'.join(rows) + '\n')
    lagged = ExtendedModel(NORTH, EAST, Effects({'motion_lag': 3.0}))
    plain = ExtendedModel(NORTH, EAST, Effects({'motion_lag': 0.0, 'heavy_tails': 1000.0}))
    out1, out2 = tmp_path / 'a.csv', tmp_path / 'b.csv'
    simulate_csv(src, out1, lagged, 1.0, 9)
    simulate_csv(src, out2, plain, 1.0, 9)
    a = np.genfromtxt(out1, delimiter=',', names=True)
    b = np.genfromtxt(out2, delimiter=',', names=True)
    na, _ = difference(a['lat'], a['lon'], a['truth_lat'], a['truth_lon'])
    ref = lagged.simulate(streams.agent_keys(9, ['w']), 30)[:, 0, 0]
    assert na[5:] == pytest.approx(ref[5:] - 3.0, abs=1e-4)
    assert len(b) == 30
