"""The churn soak, short: about 10 agents coming and going for 5 simulated minutes."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / 'bench'))
import soak_churn  # noqa: E402

pytestmark = pytest.mark.integration


def test_short_churn_soak():
    """
    What the node guarantees of agents that come and go, whatever the machine's speed.

    The driver waits (up to 60 s of wall time a step) for the node to match
    each agent alive before the clock moves on, and holds a life that has had
    no fix yet past its end (up to two simulated minutes): what is asserted is
    that the node serves every agent that keeps publishing, however late a
    busy machine lets it (once a returning agent's poses went to the
    subscription of its last life, released a moment later, and its short
    life ended before the node subscribed again). How many lives a node
    racing discovery misses, and its memory over hours, are ``make soak``'s
    to report.
    """
    r = soak_churn.run(concurrent=10, sim_s=300, life_s=(20, 80), sample_s=30,
                       warmup_s=60, max_speed=15.0, wait_matched_s=60.0)
    summary = {k: v for k, v in r.items() if k != 'node_log'}
    # what went wrong first: which agents have fixes off their streams (all of
    # them, named: pytest cuts a long dict short), then where
    off = summary.pop('off_stream_by_agent')
    counts = ('departures', 'returns', 'lives_never_served', 'released', 'served_at_end',
              'alive_at_end', 'served_max')
    summary = {'agents_off_stream': sorted(off), **{k: summary.pop(k) for k in counts},
               'off_stream_by_agent': off, **summary}
    # a string, not the dict: pytest cuts a dict's repr after four keys
    summary = ', '.join(f'{k}: {v}' for k, v in summary.items())
    # the driver's schedule (seeded): some 50 departures and 10 returns
    assert r['departures'] >= 30 and r['returns'] >= 5, summary
    assert r['missing'] == 0 and r['unexpected'] == 0 and r['duplicates'] == 0, summary
    assert r['max_error_diff_m'] <= soak_churn.STREAM_TOLERANCE_M, summary
    assert r['agents_checked'] == r['agents_ever'], summary
    # every life was matched before it ended, so every life got fixes
    assert r['lives_never_served'] == 0, summary
    # the node serves the agents present, not all that ever came, and at the end
    # (past every departure's timeout) exactly those alive, every departure released
    # but the names that came back before their release
    assert r['served_max'] < 2 * 10, summary
    assert r['served_at_end'] == r['alive_at_end'], summary
    assert r['released'] >= r['departures'] - r['returns'], summary
