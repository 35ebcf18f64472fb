"""The fix engine with agents that come and go (attach, detach, grow)."""

import numpy as np
import pytest

from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import AxisParams
from gps_error_ros.model.effects import build_model, effects_from_dict
from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.profiles import load_profile
from gps_error_ros.sim.engine import FixEngine, NS

LAT, LON = 40.75, -73.99
AR = load_profile('DS1').model()
EXTENDED = build_model(
    AxisParams(0.1, (0.9, -0.1), 1.0), AxisParams(-0.05, (0.7,), 0.8),
    effects_from_dict({'heavy_tails': {'dof': 5.0},
                       'variance_regimes': {'scales': [1.0, 2.5],
                                            'transition': [[0.97, 0.03], [0.06, 0.94]]}}))
START = 100      # the engine's first clock step


def errors_by_step(fixes, slot):
    """Return {step: (north, east)} of ``slot``'s fixes."""
    out = {}
    for f in fixes:
        for i, lat, lon in zip(f.agents, f.lat, f.lon):
            if i == slot:
                n, e = difference(lat, lon, LAT, LON)
                out[f.stamp_ns // NS] = (float(n), float(e))
    return out


@pytest.mark.parametrize('model', [AR, EXTENDED], ids=['ar', 'extended'])
def test_an_agent_attached_late_gets_its_stream_from_the_start(model):
    key = streams.agent_key(5, 'ped7')
    eng = FixEngine(model, np.zeros(3, dtype=np.uint64), active=False)
    eng.attach([0], [streams.agent_key(5, 'ped0')])
    out = []
    for k in range(START, START + 60):
        if k == START + 30:
            # attached while step k - 1 still waits for ped0's truth: it is
            # served for ped7 too
            assert [step.model_step for step in eng.pending] == [k - 1]
            eng.attach([1], [key])
            eng.add_truth(1, (k - 2) * NS, LAT, LON, 0.0)
        if k >= START + 30:
            eng.add_truth(1, k * NS, LAT, LON, 0.0)
        out += eng.on_clock(k * NS)
        eng.add_truth(0, k * NS, LAT, LON, 0.0)    # ped0's truth after the tick
    got = errors_by_step(out, 1)
    expected = model.simulate(key, 60, start=START)[:, 0]
    steps = sorted(got)
    assert steps == list(range(START + 29, START + 60))
    np.testing.assert_allclose([got[k] for k in steps], expected[29:], atol=1e-6)
    assert errors_by_step(out, 2) == {}          # a free slot is never served
    assert eng.stats.skipped_no_truth == 0       # nor counted as skipped
    ped0 = errors_by_step(out, 0)
    assert sorted(ped0) == list(range(START, START + 59))


def test_detach_reattach_and_grow_keep_every_agent_on_its_stream():
    keys = [streams.agent_key(5, n) for n in ('a', 'b', 'c')]
    eng = FixEngine(EXTENDED, keys[:1])
    out = []
    for k in range(START, START + 80):
        if k == START + 10:
            eng.grow(3)
            eng.attach([1, 2], keys[1:])
        if k == START + 40:
            eng.detach([1])
        if k == START + 50:
            eng.attach([1], [keys[1]])               # 'b' comes back
        if k == START + 60:
            eng.detach([2])
            eng.attach([2], [keys[0] ^ np.uint64(1)])   # the slot reused by another
        for slot in np.flatnonzero(eng.active):
            eng.add_truth(slot, k * NS, LAT, LON, 0.0)
        out += eng.on_clock(k * NS)
    expected = EXTENDED.simulate(np.array(keys, dtype=np.uint64), 80, start=START)
    for slot, name_index, served in ((0, 0, range(START, START + 80)),
                                     (1, 1, [*range(START + 10, START + 40),
                                             *range(START + 50, START + 80)]),
                                     (2, 2, range(START + 10, START + 60))):
        got = errors_by_step(out, slot)
        if slot == 2:
            got = {k: v for k, v in got.items() if k < START + 60}
        assert sorted(got) == list(served), slot
        np.testing.assert_allclose([got[k] for k in served],
                                   expected[np.array(served) - START, name_index],
                                   atol=1e-6)
    assert errors_by_step(out, 3) == {}
    assert eng.stats.skipped_no_truth == 0


def test_attaching_a_taken_slot_is_refused():
    eng = FixEngine(AR, [streams.agent_key(1, 'x')])
    with pytest.raises(ValueError, match='taken'):
        eng.attach([0], [streams.agent_key(1, 'y')])


def test_an_agent_without_truth_does_not_hold_back_the_others():
    keys = [streams.agent_key(5, n) for n in ('quiet', 'busy')]
    eng = FixEngine(AR, keys, max_pose_age=3.0)
    for k in range(START, START + 10):
        eng.add_truth(1, k * NS, LAT, LON, 0.0)      # only 'busy' has truth
        got = eng.on_clock(k * NS)
        # busy's fix of step k comes at step k, not max_pose_age later
        assert [(f.stamp_ns // NS, list(f.agents)) for f in got] == [(k, [1])]
    assert len(eng.pending) == 3      # quiet's steps wait until 3 s after them


def test_conditional_covariance_is_the_regimes_prediction_even_after_a_late_attach():
    key = streams.agent_key(5, 'ped7')
    whole = FixEngine(EXTENDED, [key], conditional_cov=True)
    late = FixEngine(EXTENDED, np.zeros(2, dtype=np.uint64), active=False,
                     conditional_cov=True)
    late.attach([0], [streams.agent_key(5, 'other')])
    covs = {'whole': {}, 'late': {}}
    for k in range(START, START + 60):
        if k == START + 25:
            late.attach([1], [key])
        for name, eng, slot in (('whole', whole, 0), ('late', late, 1)):
            eng.add_truth(slot, k * NS, LAT, LON, 0.0)
            for f in eng.on_clock(k * NS):
                for i, c in zip(f.agents, f.cov):
                    if i == slot:
                        covs[name][f.stamp_ns // NS] = c
    # what the model predicts, a step before each step, from the stream
    state = EXTENDED.initial_state(np.array([key]), START)
    expected = {START: EXTENDED.predictive_cov(state, first=True)[0]}
    for k in range(START + 1, START + 60):
        expected[k] = EXTENDED.predictive_cov(state)[0]
        EXTENDED.advance(state, np.array([key]), k)
    assert sorted(covs["whole"]) == list(range(START, START + 60))
    for k, c in covs['whole'].items():
        np.testing.assert_allclose(c, expected[k], rtol=1e-12)
    assert len(covs['late']) >= 30
    for k, c in covs['late'].items():
        np.testing.assert_allclose(c, expected[k], rtol=1e-12)
    sizes = {round(float(c[0, 0]), 9) for c in covs['whole'].values()}
    assert len(sizes) == 3          # the first step (regimes unknown), then each regime


PREPARED = '''
import sys
import numpy as np
from gps_error_ros.model.profiles import load_profile
from gps_error_ros.model.streams import agent_key
from gps_error_ros.sim.engine import FixEngine, NS
eng = FixEngine(load_profile({profile!r}).model(), np.zeros(4, dtype=np.uint64),
                active=False, conditional_cov={cov})
eng.prepare_attach()
for k in range(1000, 1100):
    eng.on_clock(k * NS)
before = set(sys.modules)
eng.attach([0, 1], [agent_key(3, 'a'), agent_key(3, 'b')])
print(sorted(set(sys.modules) - before))
'''


@pytest.mark.parametrize('profile,cov', [('DS1', False), ('DS1', True), ('DS7', False)])
def test_an_attach_after_prepare_attach_imports_nothing(profile, cov):
    # The first attach once imported scipy.signal (1-2 s; more under load),
    # stopping a pattern node while the simulator's clock ran on. In a fresh
    # interpreter, so that other tests' imports do not hide it.
    import subprocess
    import sys
    out = subprocess.run([sys.executable, '-c', PREPARED.format(profile=profile, cov=cov)],
                         capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == '[]', out.stdout
