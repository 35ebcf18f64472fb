"""Fix availability: the outage process, its profile section, and no change without it."""

import numpy as np
import pytest

from gps_error_ros.model import streams
from gps_error_ros.model.availability import (Availability, runs_without_fix,
                                              WithAvailability)
from gps_error_ros.model.profiles import load_profile, profile_from_dict, ProfileError

SECTION = {'outage_rate': 0.02, 'durations': [[1, 0.3], [3, 0.4], [10, 0.3]]}


def profile(availability=SECTION):
    raw = {'schema': 1, 'name': 'av', 'description': 'test', 'source': 'test',
           'rate_hz': 1.0,
           'axes': {'north': {'delta': 0.1, 'phi': [0.9], 'sigma_w': 1.0},
                    'east': {'delta': 0.0, 'phi': [0.8], 'sigma_w': 1.2}}}
    if availability is not None:
        raw['availability'] = availability
    return profile_from_dict(raw, 'test.yaml')


def runs(mask):
    """Return the lengths of the whole runs of False (those cut at either end left out)."""
    out = runs_without_fix(mask)
    if out and not mask[0]:
        out = out[1:]
    if out and not mask[-1]:
        out = out[:-1]
    return out


def test_outages_follow_the_declared_law():
    model = profile().model()
    av = model.availability
    keys = streams.agent_keys(3, [f'a{i}' for i in range(200)])
    mask = model.simulate_fix(keys, 3000, start=50)
    n = mask.size
    frac = 1.0 - mask.mean()
    assert av.outage_fraction == pytest.approx(4.5 / (4.5 + 50.0))     # E[L] = 4.5
    # agents are independent; within one, outages are ~50 steps apart
    se = np.sqrt(av.outage_fraction * (1 - av.outage_fraction) / n * 60)
    assert abs(frac - av.outage_fraction) < 4 * se, (frac, av.outage_fraction, se)
    lengths = [r for row in mask for r in runs(row[100:])]   # after the start's residuals
    got = {k: lengths.count(k) / len(lengths) for k in (1, 3, 10)}
    assert set(lengths) == {1, 3, 10}       # never two outages back to back
    for k, p in zip(av.lengths, av.probs):
        assert abs(got[k] - p) < 4 * np.sqrt(p * (1 - p) / len(lengths)), (k, got[k], p)


def test_outages_are_each_agents_own_stream():
    model = profile().model()
    keys = streams.agent_keys(3, ['x', 'y', 'z'])
    crowd = model.simulate_fix(keys, 400, start=7)
    alone = model.simulate_fix(keys[1:2], 400, start=7)
    np.testing.assert_array_equal(crowd[1:2], alone)
    state = model.state_after(keys, 7, 300)      # caught up = stepped
    np.testing.assert_array_equal(model.fix_mask(state), crowd[:, 300 - 7])


def test_the_errors_are_the_inner_models_bit_for_bit():
    with_av, without = profile().model(), profile(None).model()
    assert isinstance(with_av, WithAvailability) and not isinstance(without, WithAvailability)
    keys = streams.agent_keys(5, ['a', 'b'])
    s1, s2 = with_av.initial_state(keys, 10), without.initial_state(keys, 10)
    np.testing.assert_array_equal(with_av.errors(s1), without.errors(s2))
    for k in range(11, 200):
        np.testing.assert_array_equal(with_av.advance(s1, keys, k),
                                      without.advance(s2, keys, k))
    np.testing.assert_array_equal(without.fix_mask(s2), [True, True])
    assert load_profile('DS5').availability is None


@pytest.mark.parametrize('section, expected', [
    ({'outage_rate': 0.1}, r"exactly \['outage_rate', 'durations'\]"),
    ({'outage_rate': 0.1, 'durations': [[2, 0.5, 1]]}, r'\[value, probability\] pairs'),
    ({'outage_rate': 1.5, 'durations': [[1, 1.0]]}, 'availability.outage_rate'),
    ({'outage_rate': 0.1, 'durations': [[0, 1.0]]}, 'availability.durations'),
    ({'outage_rate': 0.1, 'durations': [[2, 0.5], [3, 0.4]]}, 'sum to 1'),
    ({'outage_rate': 0.1, 'durations': [[2, 0.5], [2, 0.5]]}, 'appears twice'),
])
def test_a_bad_section_is_refused_naming_the_key(section, expected):
    with pytest.raises(ProfileError, match=expected):
        profile(section)


def test_round_trip_through_the_mapping():
    av = profile().availability
    assert isinstance(av, Availability)
    assert profile(av.to_dict()).availability == av


def test_runs_without_fix_counts_the_ends_too():
    assert runs_without_fix([False, True, False, False, True, False]) == [1, 2, 1]
    assert runs_without_fix([True, True]) == []
