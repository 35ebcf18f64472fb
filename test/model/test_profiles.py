"""Every profile loads or fails as specified; bad files name file and key."""

import numpy as np
import pytest

from gps_error_ros.model.profiles import builtin_names, load_profile, \
    ProfileError, ProfileNotFittedError

TABLE_II = {
    'DS5': ((0.07, [1.18, -0.06, -0.14], 1.52), (-0.02, [1.15, -0.03, -0.14], 1.58)),
    'DS2': ((0.03, [1.31, -0.04, -0.28], 0.49), (-0.02, [1.66, -0.72, 0.04], 0.39)),
    'DS1': ((-0.02, [1.71, -0.75, -0.04], 0.72), (0.02, [1.52, -0.53, -0.07], 0.93)),
    'DS7': ((0.02, [1.58, -0.53, -0.06], 0.53), (-0.11, [1.23, -0.15, -0.1], 0.99)),
}


def test_builtin_names():
    assert builtin_names() == [f'DS{i}' for i in range(1, 8)] + ['phone-suburban-drive',
                                                                 'snapshot-receiver-on-foot']


def test_the_receiver_profile_loads_by_name_and_carries_its_failures():
    prof = load_profile('Snapshot-Receiver-On-Foot')
    assert prof.name == 'snapshot-receiver-on-foot' and prof.gross_failures.rate > 0.01
    assert prof.fit['gross_failures']['count'] > 100
    # the walks' east biases differ by metres: the profile carries their spread, as a
    # part held for the walk (it does not wander away within one)
    assert prof.population is not None and prof.population.run_bias_sd_m[1] > 2.0
    assert prof.population.bias_sd_total_m[1] > prof.population.bias_sd_m[1]
    err = prof.model().simulate(np.array([1, 2], dtype=np.uint64), 600)
    assert np.isfinite(err).all() and np.hypot(*err.T).max() > 30.0


@pytest.mark.parametrize('name', sorted(TABLE_II))
def test_fitted_profiles_carry_table_ii_exactly(name):
    p = load_profile(name.lower())
    assert p.name == name and p.rate_hz == 1.0
    for axis, (delta, phi, sigma) in zip(('north', 'east'), TABLE_II[name]):
        ax = p.axes[axis]
        assert (ax.delta, list(ax.phi), ax.sigma_w) == (delta, phi, sigma)
    assert np.all(p.model().stationary_sd > 0)


@pytest.mark.parametrize('name', ['DS3', 'DS4', 'DS6'])
def test_unfitted_profiles_load_but_refuse_simulation(name):
    p = load_profile(name)
    assert not p.fitted and '9th Avenue' in p.description
    with pytest.raises(ProfileNotFittedError) as exc:
        p.model()
    for fitted in ('DS1', 'DS2', 'DS5', 'DS7'):
        assert fitted in str(exc.value)


GOOD = """schema: 1
name: custom
description: test
source: test
rate_hz: 1.0
axes:
  north: {delta: 0.1, phi: [0.9], sigma_w: 0.5}
  east:  {delta: 0.0, phi: [0.5, 0.2], sigma_w: 0.4}
"""


def test_profile_by_path(tmp_path):
    f = tmp_path / 'mine.yaml'
    f.write_text(GOOD + 'vertical_sd: 3.0\n')
    p = load_profile(str(f))
    assert p.axes['east'].order == 2
    assert p.vertical_variance() == 9.0


@pytest.mark.parametrize('edit, key', [
    (lambda s: s.replace('schema: 1', 'schema: 2'), 'schema'),
    (lambda s: s + 'colour: red\n', 'colour'),
    (lambda s: s.replace('phi: [0.9]', 'phi: [1.1]'), 'axes.north'),
    (lambda s: s.replace('sigma_w: 0.5', 'sigma_w: -0.5'), 'axes.north.sigma_w'),
    (lambda s: s.replace('sigma_w: 0.5', 'sigma_w: .nan'), 'axes.north.sigma_w'),
    (lambda s: s.replace('delta: 0.1', 'delta: abc'), 'axes.north.delta'),
    (lambda s: s.replace('phi: [0.9]', 'phi: []'), 'axes.north.phi'),
    (lambda s: s.replace('rate_hz: 1.0\n', ''), 'rate_hz'),
    (lambda s: s.replace('  east:  {delta: 0.0, phi: [0.5, 0.2], sigma_w: 0.4}\n', ''),
     'axes'),
    (lambda s: s.replace('delta: 0.1, ', ''), 'axes.north'),
    (lambda s: s + 'effects: {heavy_tails: {nu: 4}}\n', 'effects'),
    (lambda s: s.replace('phi: [0.9]', 'phi: [0.9], gain: 2'), 'axes.north.gain'),
])
def test_invalid_profile_names_file_and_key(tmp_path, edit, key):
    f = tmp_path / 'bad.yaml'
    f.write_text(edit(GOOD))
    with pytest.raises(ProfileError) as exc:
        load_profile(str(f))
    assert str(f) in str(exc.value)
    assert key in str(exc.value)


def test_missing_malformed_and_unknown(tmp_path):
    with pytest.raises(ProfileError, match='not found'):
        load_profile(str(tmp_path / 'none.yaml'))
    f = tmp_path / 'broken.yaml'
    f.write_text('schema: [1\n')
    with pytest.raises(ProfileError, match='malformed YAML'):
        load_profile(str(f))
    f.write_text('- 1\n- 2\n')
    with pytest.raises(ProfileError, match='mapping'):
        load_profile(str(f))
    with pytest.raises(ProfileError, match='DS1, DS2'):
        load_profile('DS9')
    with pytest.raises(ProfileError, match='unknown profile'):
        load_profile('manhattan')
