"""The agent_pattern watcher's bookkeeping, on a stand-in for the node's graph."""

import numpy as np

from gps_error_ros.ros.agent_watch import AgentPattern, AgentWatcher

POSE = 'geometry_msgs/msg/PoseStamped'


class Graph:
    """What the watcher asks of the error node: topics, slots, stamps, publishers."""

    def __init__(self):
        self.topics, self.publishers = {}, set()
        self.slots, self.newest, self.now = [], np.zeros(0, dtype=np.int64), 0
        self.opened, self.closed = [], []
        self.prepared = False

    def prepare_attach(self):
        self.prepared = True

    def add(self, name, t_ns):
        self.topics[f'/peds/{name}/pose'] = [POSE]
        self.topics[f'/peds/{name}/fix'] = ['sensor_msgs/msg/NavSatFix']
        self.publishers.add(name)
        self.now = t_ns

    def get_topic_names_and_types(self):
        return sorted(self.topics.items())

    def open_agents(self, new, fix_topics):
        out = []
        for name, _ in new:
            slot = self.slots.index(None) if None in self.slots else len(self.slots)
            if slot == len(self.slots):
                self.slots.append(None)
                self.newest = np.r_[self.newest, -1]
            self.slots[slot] = name
            self.newest[slot] = -1
            out.append(slot)
        self.opened += [n for n, _ in new]
        return out

    def close_agents(self, slots):
        self.closed += [self.slots[s] for s in slots]
        for s in slots:
            self.slots[s] = None

    def now_ns(self):
        return self.now

    def newest_truth_ns(self):
        return self.newest

    def truth_publishers(self, slot):
        return int(self.slots[slot] in self.publishers)

    def get_logger(self):
        return self

    def info(self, *_):
        pass

    def warning(self, *_):
        pass


def test_agents_are_served_released_and_served_again():
    g = Graph()
    w = AgentWatcher(g, AgentPattern('/peds/*/pose', '/', POSE), timeout_s=5.0)
    assert g.prepared                               # before the first agent comes
    for i in range(3):
        g.add(f'p{i}', 1_000_000_000)
    w.scan()
    assert g.opened == ['p0', 'p1', 'p2'] and w.index == {'p0': 0, 'p1': 1, 'p2': 2}
    w.scan()                                        # nothing new: nothing opened again
    assert len(g.opened) == 3
    g.newest[:] = 2_000_000_000                     # truth flowed until t = 2 s
    g.publishers.discard('p1')                      # p1's publisher left ...
    del g.topics['/peds/p1/pose']
    g.now = 6_000_000_000                           # 4 s later: not yet stale
    w.scan()
    assert g.closed == [] and w.stale == 0
    g.now = 8_000_000_000                           # 6 s: p1 released, p0 and p2 stale
    w.scan()
    assert g.closed == ['p1'] and w.stale == 2 and w.released == 1
    assert 'p1' not in w.index and '/peds/p1/pose' not in w._served_topics()
    g.add('p1', 9_000_000_000)                      # p1 comes back: served again
    w.scan()
    assert g.opened[-1] == 'p1' and w.index['p1'] == 1


def test_remembered_misses_stay_bounded():
    p = AgentPattern('/peds/*/pose', '/', POSE)
    for k in range(20):                             # topics that come and go
        listing = [(f'/other/t{k}_{i}', ['x/msg/Y']) for i in range(500)]
        assert p.scan(listing) == ({}, [])
    assert len(p.misses) <= 2 * 500 + 1000 + 500
    found, wrong = p.scan([('/peds/a/pose', [POSE]), ('/peds/b/pose', ['x/msg/Y'])])
    assert found == {'a': '/peds/a/pose'} and wrong == ['/peds/b/pose (x/msg/Y)']
