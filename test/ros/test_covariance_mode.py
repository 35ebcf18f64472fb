"""covariance_mode conditional: each fix's covariance is the model's prediction for it."""

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import NavSatFix

from gps_error_ros.model.profiles import builtin_dir, load_profile_file
from gps_error_ros.model.streams import agent_key
from ros_harness import DATUM_ARG, drive, NS, pose_msg, stamp_ns, start, T0, unique_ns

pytestmark = pytest.mark.integration
SEED = 4
STEPS = 50


def regime_profile(tmp_path):
    raw = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    raw['effects'] = {'variance_regimes': {'scales': [1.0, 2.5],
                                           'transition': [[0.9, 0.1], [0.2, 0.8]]}}
    path = tmp_path / 'regimes.yaml'
    path.write_text(yaml.safe_dump(raw))
    return path


def expected(path, name):
    """Return {step: ENU 3x3 covariance (9)} the model predicts for agent ``name``."""
    profile = load_profile_file(path)
    model = profile.model()
    keys = np.array([agent_key(SEED, name)], dtype=np.uint64)
    state = model.initial_state(keys, T0)
    covs = {T0: model.predictive_cov(state, first=True)[0]}
    for k in range(T0 + 1, T0 + STEPS):
        covs[k] = model.predictive_cov(state)[0]
        model.advance(state, keys, k)
    vert = profile.vertical_variance(model)
    return {k: [c[1, 1], c[1, 0], 0.0, c[0, 1], c[0, 0], 0.0, 0.0, 0.0, vert]
            for k, c in covs.items()}


@pytest.mark.parametrize('crowd', [False, True], ids=['one agent', 'crowd'])
def test_each_fix_carries_the_models_prediction(tmp_path, peer, crowd):
    path = regime_profile(tmp_path)
    ns = unique_ns()
    names = ['ann', 'bob'] if crowd else ['']
    extra = ['agents:=["ann", "bob"]'] if crowd else []
    node = start(ns, f'profile:={path}', DATUM_ARG, f'seed:={SEED}',
                 'covariance_mode:=conditional', *extra)
    prefix = {n: f'{ns}/{n}/' if n else f'{ns}/' for n in names}
    pubs = {n: peer.publisher(PoseStamped, prefix[n] + 'pose') for n in names}
    boxes = {n: peer.collect(NavSatFix, prefix[n] + 'fix') for n in names}
    for n in names:
        peer.wait_connected(pubs[n], prefix[n] + 'fix', node)
    if crowd:
        for k in range(T0, T0 + STEPS):
            for n in names:
                pubs[n].publish(pose_msg(k * NS))
            peer.set_clock(k * NS)
            peer.spin_until(lambda: all(b and stamp_ns(b[-1].header.stamp) >= (k - 1) * NS
                                        for b in boxes.values()), 5)
        peer.set_clock((T0 + STEPS) * NS)
        peer.spin_for(1.0)
    else:
        drive(peer, pubs[''], boxes[''], STEPS)
    rc, out = node.stop()
    assert rc == 0, out
    for n in names:
        want = expected(path, n)
        got = {stamp_ns(f.header.stamp) // NS: list(f.position_covariance) for f in boxes[n]}
        assert len(got) >= STEPS - 1, n
        for k, c in got.items():
            assert c == pytest.approx(want[k], rel=1e-12), (n, k)
        assert all(f.position_covariance_type == NavSatFix.COVARIANCE_TYPE_KNOWN
                   for f in boxes[n])
        assert len({round(c[0], 9) for c in got.values()}) == 3, n    # it varies
