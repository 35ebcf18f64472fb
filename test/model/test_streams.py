"""Counter-based streams: distribution, independence, stability."""

import numpy as np
import pytest
from scipy import stats

from gps_error_ros.model.effect_kinds.variance_regimes import Regimes
from gps_error_ros.model import streams


def test_normals_are_standard_normal():
    keys = streams.agent_keys(1, [f'a{i}' for i in range(100)])
    z = streams.normal_block(keys, streams.DOMAIN_STEP, 0, 1000).reshape(-1)
    assert stats.kstest(z, 'norm').pvalue > 1e-3
    assert abs(z.mean()) < 5 / np.sqrt(z.size)
    assert abs(z.var() - 1) < 5 * np.sqrt(2 / z.size)


def test_normals_are_uncorrelated_across_axes_steps_and_agents():
    keys = streams.agent_keys(2, [f'a{i}' for i in range(50)])
    z = streams.normal_block(keys, streams.DOMAIN_STEP, 0, 4000)   # (t, n, 2)
    bound = 5 / np.sqrt(z.shape[0] * z.shape[1])
    assert abs(np.mean(z[..., 0] * z[..., 1])) < bound
    assert abs(np.mean(z[1:] * z[:-1])) < bound
    assert abs(np.mean(z[:, 1:] * z[:, :-1])) < bound


def test_domains_differ():
    keys = streams.agent_keys(2, ['a'])
    a = streams.normal_pairs(keys, streams.DOMAIN_STEP, 5)
    b = streams.normal_pairs(keys, streams.DOMAIN_INIT, 5)
    assert not np.allclose(a, b)


def test_agent_key_is_stable_across_processes():
    # BLAKE2b of (seed, name): fixed forever, so runs and shards agree.
    assert int(streams.agent_key(0, '')) == int(streams.agent_key(0, ''))
    import subprocess
    import sys
    out = subprocess.run(
        [sys.executable, '-c',
         'from gps_error_ros.model.streams import agent_key; print(int(agent_key(7, "ped_3")))'],
        capture_output=True, text=True, check=True,
        env={'PYTHONHASHSEED': '123', 'PATH': ''})
    assert int(out.stdout) == int(streams.agent_key(7, 'ped_3'))


@pytest.mark.parametrize('seed', [-1, 2 ** 64, 1.5, True])
def test_bad_seed(seed):
    with pytest.raises((ValueError, TypeError)):
        streams.agent_key(seed)


def test_index_range_checked():
    with pytest.raises(ValueError, match='stream index'):
        streams.normal_pairs(streams.agent_keys(0, ['a']), 0, -1)


CHUNK = streams._CHUNK


@pytest.mark.parametrize('n, count', [(1, 2 * CHUNK + 5), (3, CHUNK), (2, CHUNK - 1),
                                      (5, 7), (CHUNK + 3, 2), (700, 30), (1, 1)])
@pytest.mark.parametrize('by_agent', [False, True])
def test_a_block_is_the_pairs_drawn_one_index_at_a_time(n, count, by_agent):
    """Whatever the layout and its chunks, a block holds ``normal_pairs``'s words."""
    # keys near the top of the word, so that the positions' sums wrap
    keys = np.uint64(2 ** 64 - 40) - np.arange(n, dtype=np.uint64) * np.uint64(7919)
    start = 2 ** 48 - count - 3
    block = streams.normal_block_axes(keys, streams.DOMAIN_STEP, start, count, by_agent)
    assert block.shape == ((2, n, count) if by_agent else (2, count, n))
    for j in sorted({0, min(1, count - 1), count // 2, count - 1}):
        pairs = streams.normal_pairs(keys, streams.DOMAIN_STEP, start + j)   # (n, 2)
        got = block[:, :, j] if by_agent else block[:, j, :]
        assert np.array_equal(got, pairs.T), j


def test_a_block_past_the_counter_is_refused():
    keys = streams.agent_keys(0, ['a', 'b'])
    with pytest.raises(ValueError, match='stream index'):
        streams.normal_block_axes(keys, streams.DOMAIN_STEP, 2 ** 48 - 3, 4, by_agent=True)
    with pytest.raises(ValueError, match='stream index'):
        streams.normal_block_axes(keys, streams.DOMAIN_STEP, -1, 4)


def _recorded_draws(monkeypatch):
    """Record (domain, position) of every draw the model makes."""
    seen = []
    for name in ('normal_pairs', 'uniform_pairs'):
        real = getattr(streams, name)

        def spy(keys, domain, index, real=real):
            for i in np.atleast_1d(index):
                seen.append((int(domain), int(i)))
            return real(keys, domain, index)

        monkeypatch.setattr(streams, name, spy)
    return seen


def test_every_draw_of_an_initial_state_has_a_word_of_its_own(monkeypatch):
    """At the largest order, with regimes: no two draws share a position."""
    from gps_error_ros.model.ar_model import AxisParams, MAX_ORDER
    from gps_error_ros.model.effects import Effects, ExtendedModel

    phi = (0.5,) + (0.01,) * (MAX_ORDER - 1)
    model = ExtendedModel(AxisParams(0.0, phi, 1.0), AxisParams(0.0, phi, 1.0),
                          Effects({'variance_regimes': Regimes((1.0, 2.0),
                                                               ((0.9, 0.1), (0.1, 0.9)))}))
    seen = _recorded_draws(monkeypatch)
    keys = streams.agent_keys(1, ['a', 'b'])
    for step in (7, 8):                     # consecutive starts must not meet
        model.initial_state(keys, step)
    assert len(seen) == 2 * (MAX_ORDER + 1)
    assert len(set(seen)) == len(seen), 'two draws share a stream position'
    with pytest.raises(ValueError, match='slot'):
        streams.init_position(7, streams.INIT_SLOTS)


def test_orders_that_do_not_fit_the_slots_are_refused():
    from gps_error_ros.model.ar_model import AxisParams, MAX_ORDER, ModelError
    AxisParams(0.0, (0.05,) * MAX_ORDER, 1.0)
    with pytest.raises(ModelError, match='largest order'):
        AxisParams(0.0, (0.01,) * (MAX_ORDER + 1), 1.0)
