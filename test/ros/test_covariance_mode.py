"""covariance_mode conditional and reported: the model's prediction, or what the phone states."""

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import NavSatFix

from gps_error_ros.model.profiles import builtin_dir, load_profile_file
from gps_error_ros.model.streams import agent_key
from gps_error_ros.model.reported import reference_cov
from ros_harness import (covariances_ne, DATUM_ARG, drive, drive_agents, NodeProcess, NS,
                         standing_fixes, stamp_ns, start, T0, unique_ns)

pytestmark = pytest.mark.integration
SEED = 4
STEPS = 50


REPORTED = {'source': 'accuracy', 'median_m': 3.0, 'follow': 1.0, 'phi': 0.9,
            'sigma_log': 0.3, 'resolution_m': 0.5, 'scale_m': 0.0}


def regime_profile(tmp_path, reported=None, cycle=False):
    raw = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    raw['effects'] = {'variance_regimes': {'scales': [1.0, 2.5],
                                           'transition': [[0.9, 0.1], [0.2, 0.8]]}}
    if cycle:           # the periodic effect: the next phase's scale enters too,
        # and outliers: the next jump's covariance given the one under way
        raw['effects']['periodic'] = {'period_steps': 4, 'scales': [2.0, 0.5, 1.0, 0.8],
                                      'offsets': [[0.3, 0.0], [-0.3, 0.1], [0.0, -0.1],
                                                  [0.0, 0.0]]}
        raw['effects']['outliers'] = {'rate': 0.2, 'mean_steps': 2.0, 'sigma_m': 5.0}
    if reported:
        raw['reported_accuracy'] = reported
    path = tmp_path / 'regimes.yaml'
    path.write_text(yaml.safe_dump(raw))
    return path


def expected(path, name, about='truth'):
    """
    Return {step: ENU covariance (9)} the model predicts (or the phone states) for ``name``.

    ``about`` truth: the mean square about the truth, the error expected given
    the state a step before (or, for the phone's statement, the profile's mean)
    added as m m^T; mean: the covariance alone.
    """
    profile = load_profile_file(path)
    model = profile.model()
    keys = np.array([agent_key(SEED, name)], dtype=np.uint64)
    state = model.initial_state(keys, T0)
    covs = {T0: model.predictive_cov(state, first=True)[0]}
    means = {T0: model.mean}
    for k in range(T0 + 1, T0 + STEPS):
        covs[k] = model.predictive_cov(state)[0]
        # the error expected given the state: the mean plus the AR part held
        # (and the next phase's cycle offset, what is left of a jump: see below)
        means[k] = model.predictive_mean(state)[0]
        model.advance(state, keys, k)
    rep = profile.reported_accuracy
    if rep is not None:         # the stated radius follows the predicted scale
        x = rep.errors(keys, STEPS, T0)[:, 0]
        radius = rep.radius(x, np.array([covs[k] for k in sorted(covs)]), reference_cov(model))
        covs = dict(zip(sorted(covs), rep.covariance(radius)))
        means = {k: model.mean for k in covs}
    if about == 'truth':
        covs = {k: c + np.outer(means[k], means[k]) for k, c in covs.items()}
    vert = profile.vertical_variance(
        profile.model(about_truth=about == 'truth' and rep is None))
    return {k: [c[1, 1], c[1, 0], 0.0, c[0, 1], c[0, 0], 0.0, 0.0, 0.0, vert]
            for k, c in covs.items()}


@pytest.mark.parametrize('mode,crowd,cycle,about', [
    ('conditional', False, False, 'truth'), ('conditional', False, False, 'mean'),
    ('conditional', True, False, 'truth'), ('conditional', True, True, 'truth'),
    ('conditional', True, True, 'mean'), ('reported', False, False, 'truth'),
    ('reported', True, False, 'mean')],
    ids=['conditional, one agent', 'conditional, one agent, about the mean',
         'conditional, crowd', 'conditional, crowd, periodic and outliers',
         'conditional, crowd, periodic and outliers, about the mean',
         'reported, one agent', 'reported, crowd, about the mean'])
def test_each_fix_carries_the_models_prediction(tmp_path, peer, mode, crowd, cycle, about):
    path = regime_profile(tmp_path, REPORTED if mode == 'reported' else None, cycle)
    ns = unique_ns()
    names = ['ann', 'bob'] if crowd else ['']
    extra = ['agents:=["ann", "bob"]'] if crowd else []
    extra += [] if about == 'truth' else ['covariance_about:=mean']     # truth: the default
    node = start(ns, f'profile:={path}', DATUM_ARG, f'seed:={SEED}',
                 f'covariance_mode:={mode}', *extra)
    prefix = {n: f'{ns}/{n}/' if n else f'{ns}/' for n in names}
    pubs = {n: peer.publisher(PoseStamped, prefix[n] + 'pose') for n in names}
    boxes = {n: peer.collect(NavSatFix, prefix[n] + 'fix') for n in names}
    for n in names:
        peer.wait_connected(pubs[n], prefix[n] + 'fix', node)
    if crowd:
        drive_agents(peer, pubs, STEPS, lambda k: all(
            b and stamp_ns(b[-1].header.stamp) >= (k - 1) * NS for b in boxes.values()))
        peer.set_clock((T0 + STEPS) * NS)
        peer.spin_for(1.0)
    else:
        drive(peer, pubs[''], boxes[''], STEPS)
    rc, out = node.stop()
    assert rc == 0, out
    for n in names:
        want = expected(path, n, about)
        got = {stamp_ns(f.header.stamp) // NS: list(f.position_covariance) for f in boxes[n]}
        assert len(got) >= STEPS - 1, n
        for k, c in got.items():
            assert c == pytest.approx(want[k], rel=1e-12), (n, k)
        kind = NavSatFix.COVARIANCE_TYPE_KNOWN if mode == 'conditional' else \
            NavSatFix.COVARIANCE_TYPE_APPROXIMATED
        assert all(f.position_covariance_type == kind for f in boxes[n])
        assert len({round(c[0], 9) for c in got.values()}) >= 3, n    # it varies


def test_reported_mode_needs_a_reported_accuracy_section():
    args = ['--ros-args', '-r', f'__ns:={unique_ns()}', '-p', DATUM_ARG, '-p', 'profile:=DS5',
            '-p', 'covariance_mode:=reported']
    rc, out = NodeProcess(args).wait_exit()
    assert rc == 2 and 'has no reported_accuracy section' in out, out


def test_the_first_fix_states_the_stationary_law(peer):
    """A run's first error is drawn from the stationary law: so is its stated covariance."""
    fixes = standing_fixes(peer, 'DS5', 3, f'seed:={SEED}', 'covariance_mode:=conditional')
    model = load_profile_file(builtin_dir() / 'DS5.yaml').model()
    m = model.mean
    want = model.stationary_cov + np.outer(m, m)            # about the truth, the default
    got = covariances_ne(fixes)
    np.testing.assert_allclose(got[0], want, rtol=1e-9)
