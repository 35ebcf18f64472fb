"""
Soak with churn: an ``agent_pattern`` node serving agents that come and go.

The driver (this process) keeps about ``--concurrent`` agents alive on
``/<ns>/peds/<name>/pose``. Each lives a random span of simulated seconds
(uniform in ``--life-s``), then destroys its pose publisher and its fix
subscription; a new agent takes its place, and one departure in
``--return-every`` comes back later under its old name. An agent sends
poses only once the node has subscribed to it (discovery is not what is
measured). One pose per agent per simulated second, then the clock tick; the
driver waits for the previous step's fixes of the agents that sent, at most
``--max-speed`` times real time. Checked at the end, and the run fails
otherwise:

* every pose an agent sent got exactly one fix (the step of the last pose
  before a departure excepted: the node may release the agent first), and
  no step got a fix beyond the engine's rules (truth held up to
  ``max_pose_age`` after it stops, interpolated across gaps up to
  ``max(2, 2 x max_pose_age)`` s, as for an agent that comes back before its
  release);
* every fix's error is the agent's stream: ``gps_error simulate``'s value
  for (seed, name, step), from step ``T0`` (the node's ``start_time``: the
  streams do not depend on when the node read its first clock), to 1e-6 m
  (all agents up to ``--check-agents``, returners included);
* the node's resident memory, sampled every ``--sample-s`` simulated
  seconds, stays flat after the warm-up (growth at most ``--rss-growth-mb``);
* what the node serves follows the agents present, not all that ever came:
  the largest ``agents served`` of its ``/diagnostics`` stays under twice
  ``--concurrent``; and once the clock is past every departed agent's
  timeout, it serves exactly the agents alive, having released every
  departure but those whose name came back before their release and the
  lives it never served (reported as ``lives_never_served``: a life of a
  second or two of wall time at this speed can end between two of the
  node's scans on a loaded machine).
"""

import argparse
import json
import os
from pathlib import Path
import sys
import tempfile
import time

import numpy as np

from soak import rss_mb, start_node, stop_node

NS = 1_000_000_000
T0 = 1000
MAX_POSE_AGE_S = 3
MAX_GAP_S = max(2, 2 * MAX_POSE_AGE_S)     # the engine's interpolation limit
MAX_HOLD_STEPS = 120       # how long a patient driver holds a life the node has not served
AGENT_TIMEOUT_S = 5
STREAM_TOLERANCE_M = 1e-6      # a fix's error against gps_error simulate's value


class Agent:
    """The driver's side of one agent's life."""

    def __init__(self, drv, ns, name, born, life):
        from geometry_msgs.msg import PoseStamped
        from rclpy.qos import QoSProfile
        from sensor_msgs.msg import NavSatFix
        self.name, self.born, self.dies = name, born, born + life
        self.pub = drv.create_publisher(PoseStamped, f'{ns}/peds/{name}/pose',
                                        QoSProfile(depth=10))
        self.sub = drv.create_subscription(NavSatFix, f'{ns}/peds/{name}/fix',
                                           lambda m: None, QoSProfile(depth=100), raw=True)
        self.ready = False
        self.sent = []

    def close(self, drv):
        drv.destroy_publisher(self.pub)
        drv.destroy_subscription(self.sub)


class Driver:
    """The driver's bookkeeping: agents alive, departed, what each sent and got."""

    def __init__(self, drv, ns, rng, life_s, return_every, patient=False):
        self.drv, self.ns, self.rng = drv, ns, rng
        # patient: a life that has had no fix yet is held past its end (at most
        # MAX_HOLD_STEPS), so that what is judged is whether the node serves every
        # agent that keeps publishing, not how fast a loaded machine lets it
        self.patient = patient
        self.held = 0            # steps lives were held past their end, all lives
        self.life_s, self.return_every = life_s, return_every
        self.alive, self.gone = {}, []
        self.sent = {}           # name -> steps whose pose was sent, every life
        self.last = set()        # (name, step) of the last pose before a departure
        self.fixes = {}          # name -> {step: (lat, lon)}
        self.dup = 0
        self.count = 0
        self.returns = 0
        self.returned = set()
        self.lives = {}          # name -> [(first step, last step)] of each life
        self.departed = []       # (name, first step, last step) of each life that ended
        self.unseen = 0          # poses sent before the node had matched them

    def born(self, k):
        """Start a new agent (or bring a departed one back) at step ``k``."""
        back = [n for n in self.gone[-self.return_every:] if n not in self.alive]
        if self.gone and len(self.gone) % self.return_every == 0 and back:
            name = back[0]
            self.returns += 1
            self.returned.add(name)
        else:
            name = f'p{self.count}'
            self.count += 1
        life = int(self.rng.integers(*self.life_s))
        self.alive[name] = Agent(self.drv, self.ns, name, k, life)

    def depart(self, k):
        """End the agents whose life is over at ``k``; each is replaced."""
        for name in [n for n, a in self.alive.items() if a.dies <= k]:
            agent = self.alive[name]
            self.drain(agent)
            if self.patient and not self.served(agent) and k - agent.dies < MAX_HOLD_STEPS:
                self.held += 1
                continue
            if self.patient and agent.sent:
                # its last poses may still be on their way: closing the
                # publisher would drop them, and their fixes would be missing
                self.wait_last(agent)
            del self.alive[name]
            agent.close(self.drv)
            if agent.sent:
                self.last.add((name, agent.sent[-1]))
                self.lives.setdefault(name, []).append((agent.sent[0], agent.sent[-1]))
                self.departed.append((name, agent.sent[0], agent.sent[-1]))
            else:
                # a life that ended before both sides had matched sent no pose:
                # the node may never have seen it, so it may have nothing to release
                self.departed.append((name, 1, 0))
            self.gone.append(name)
            self.born(k)

    def wait_last(self, agent, timeout_s=60.0):
        """Wait up to ``timeout_s`` for the fix of ``agent``'s last pose sent."""
        end, last = time.monotonic() + timeout_s, agent.sent[-1]
        while last not in self.fixes.get(agent.name, {}) and time.monotonic() < end:
            time.sleep(0.001)
            self.drain(agent)

    def served(self, agent):
        """Return whether ``agent`` has had a fix in its present life."""
        return bool(agent.sent) and any(k >= agent.sent[0]
                                        for k in self.fixes.get(agent.name, {}))

    def never_served(self):
        """Return how many ended lives got no fix at all (sent none, or none came back)."""
        return sum(not any(a <= k <= b for k in self.fixes.get(name, {}))
                   for name, a, b in self.departed)

    def drain(self, agent):
        """Take every fix waiting for ``agent``."""
        from gps_error_ros.ros.cdr import navsatfix
        box = self.fixes.setdefault(agent.name, {})
        while True:
            taken = agent.sub.handle.take_message(agent.sub.msg_type, True)
            if taken is None:
                return
            stamp, _, lat, lon, _ = navsatfix(taken[0])
            step = stamp // NS
            self.dup += step in box
            box[step] = (lat, lon)

    def _matched(self, agent):
        if not agent.ready:
            agent.ready = agent.pub.get_subscription_count() > 0 and \
                agent.sub.get_publisher_count() > 0
        return agent.ready

    def wait_matched(self, timeout_s):
        """
        Wait up to ``timeout_s`` until the node is matched with every agent alive, now.

        Checked afresh each step, not once per life: an agent that comes back
        under its old name is matched at once with the node's subscription of
        its last life, which the node may release a moment later; the driver
        then waits for the node to subscribe again before the clock moves on.
        """
        end = time.monotonic() + timeout_s

        def matched(a):
            return a.pub.get_subscription_count() > 0 and a.sub.get_publisher_count() > 0
        while not all(matched(a) for a in self.alive.values()) and time.monotonic() < end:
            time.sleep(0.01)
        for a in self.alive.values():
            a.ready = a.ready or matched(a)

    def send(self, k, pose_msg):
        """Publish step ``k``'s pose of every agent the node has subscribed to."""
        for agent in self.alive.values():
            if self._matched(agent):
                agent.pub.publish(pose_msg)
                agent.sent.append(k)
                self.sent.setdefault(agent.name, []).append(k)

    def wait_for(self, step, timeout_s=10.0):
        """
        Wait for ``step``'s fix of every agent alive that sent it and is flowing.

        An agent flows once its first fix has come: the node's subscription
        can match the agent's publisher a moment after the agent's side saw
        it, and poses sent in between are lost (volatile QoS) before the
        node has seen the agent at all.
        """
        end = time.monotonic() + timeout_s
        for a in self.alive.values():
            self.drain(a)
        waiting = [a for a in self.alive.values() if step in a.sent[-2:]
                   and any(k >= a.sent[0] for k in self.fixes[a.name])]
        while waiting and time.monotonic() < end:
            for a in waiting:
                self.drain(a)
            waiting = [a for a in waiting if step not in self.fixes[a.name]]
            if waiting:
                time.sleep(0.0005)


def run(concurrent, sim_s, life_s=(60, 600), return_every=5, sample_s=300, warmup_s=900,
        rss_growth_mb=20.0, check_agents=300, seed=11, profile='DS1', max_speed=15.0,
        wait_matched_s=0.0):
    """
    Run the churn soak; return the result dictionary (see the module docstring).

    ``wait_matched_s`` > 0 (the test's way): before each clock step, wait up
    to that many seconds of wall time until the node has matched every agent
    alive, and hold a life past its end until it has had a fix (at most
    :data:`MAX_HOLD_STEPS` steps; counted in ``steps_held_unserved``), and
    wait as long for each step's fixes before the clock moves on, so that no
    life ends unseen and no step expires however slowly the machine
    schedules the node.
    The soak leaves discovery to race, and counts the lives it lost as
    ``lives_never_served``.
    """
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import PoseStamped
    from rclpy.node import Node
    from rclpy.qos import QoSProfile
    from rosgraph_msgs.msg import Clock

    from gps_error_ros.ros.conversions import to_stamp

    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    lat0, lon0 = 40.75, -73.99
    ns = f'/churn{os.getpid()}'
    status = {'served_max': 0, 'served': -1, 'released': 0}
    with tempfile.TemporaryDirectory() as work:
        params = Path(work, 'p.yaml')
        params.write_text('/**:\n  ros__parameters:\n    use_sim_time: true\n'
                          f'    datum: [{lat0}, {lon0}, 0.0]\n    seed: {seed}\n'
                          f'    profile: {profile}\n    max_pose_age: {MAX_POSE_AGE_S:.1f}\n'
                          f'    agent_pattern: {ns}/peds/*/pose\n'
                          f'    agent_timeout: {AGENT_TIMEOUT_S:.1f}\n'
                          # the streams begin at T0 however late the node reads
                          # the clock: a node slow to start on a loaded machine
                          # read it first at 1046, and every agent's errors
                          # were those of a stream begun there
                          f'    start_time: {T0:.1f}\n')
        node = start_node(ns, params)
        rclpy.init()
        drv = Node('churn_driver')

        # The driver never spins: every subscription is taken from by hand. (It
        # once spun for the /diagnostics callback, and spin_once took and threw
        # away one agent's fix now and then: one fix "lost" per step.)
        diagnostics = drv.create_subscription(DiagnosticArray, '/diagnostics',
                                              lambda m: None, QoSProfile(depth=10))

        def read_status():
            while (taken := diagnostics.handle.take_message(DiagnosticArray, False)):
                for st in taken[0].status:
                    if st.hardware_id == f'{ns}/gps_error_node':
                        v = {kv.key: kv.value for kv in st.values}
                        status['served_max'] = max(status['served_max'],
                                                   int(v['agents served']))
                        status['served'] = int(v['agents served'])
                        status['released'] = int(v.get('agents released', 0))
        clock = drv.create_publisher(Clock, '/clock', QoSProfile(depth=10))
        crowd = Driver(drv, ns, np.random.default_rng(seed), life_s, return_every,
                       patient=wait_matched_s > 0)
        rss = []
        try:
            deadline = time.monotonic() + 60
            while not any(e.node_namespace == ns
                          for e in drv.get_subscriptions_info_by_topic('/clock')):
                if time.monotonic() > deadline or node.poll() is not None:
                    raise RuntimeError('the node did not come up')
                time.sleep(0.1)
            time.sleep(0.5)
            clock.publish(Clock(clock=to_stamp(T0 * NS)))   # the streams' first step
            time.sleep(1.0)
            msg = PoseStamped()
            msg.pose.orientation.w = 1.0
            for _ in range(concurrent):
                crowd.born(T0)
            wall0 = time.monotonic()
            for k in range(T0 + 1, T0 + sim_s + 1):
                crowd.depart(k)
                msg.header.stamp = to_stamp(k * NS)
                if wait_matched_s > 0:
                    crowd.wait_matched(wait_matched_s)
                crowd.send(k, msg)
                clock.publish(Clock(clock=to_stamp(k * NS)))
                # patient: as long as the node needs (a step expires, and is
                # skipped, only once the clock is max_pose_age past it)
                crowd.wait_for(k - 1, wait_matched_s if wait_matched_s > 0 else 10.0)
                read_status()
                ahead = (k - T0) / max_speed - (time.monotonic() - wall0)
                if ahead > 0:
                    time.sleep(ahead)
                if (k - T0) % sample_s == 0 and k - T0 >= warmup_s:
                    rss.append(rss_mb(node.pid))
            wall = time.monotonic() - wall0
            for agent in crowd.alive.values():
                crowd.drain(agent)
                if agent.sent:
                    crowd.lives.setdefault(agent.name, []).append(
                        (agent.sent[0], agent.sent[-1]))
            # past every departed agent's timeout, the node must serve exactly
            # the agents alive: released all the departures but those whose
            # name came back before its release (waited for: the node scans
            # once a second, and the graph lags on a loaded machine)
            clock.publish(Clock(clock=to_stamp((T0 + sim_s + AGENT_TIMEOUT_S + 2) * NS)))
            settled = len(crowd.gone) - crowd.returns - crowd.never_served()
            end = time.monotonic() + 30
            while time.monotonic() < end and not (
                    status['served'] == len(crowd.alive) and status['released'] >= settled):
                read_status()
                time.sleep(0.1)
        finally:
            drv.destroy_node()
            rclpy.try_shutdown()
            out = stop_node(node, timeout=60)
    result = _verdict(crowd, T0 + sim_s, seed, profile, (lat0, lon0), check_agents)
    growth = rss[-1] - rss[0] if len(rss) > 1 else 0.0
    result.update({
        'concurrent': concurrent, 'simulated_s': sim_s, 'wall_s': wall,
        'speed_x_real_time': sim_s / wall, 'rss_mb_samples': [round(r, 1) for r in rss],
        'rss_growth_mb': growth, 'served_max': status['served_max'],
        'served_at_end': status['served'], 'alive_at_end': len(crowd.alive),
        'released': status['released'], 'lives_never_served': crowd.never_served(),
        'steps_held_unserved': crowd.held,
        'node_summary': [ln for ln in out.splitlines() if 'at shutdown' in ln],
        'node_log': out.splitlines()[-200:]})
    result['passed'] = (result['missing'] == 0 and result['unexpected'] == 0
                        and result['duplicates'] == 0
                        and result['max_error_diff_m'] <= STREAM_TOLERANCE_M
                        and growth <= rss_growth_mb
                        and status['served_max'] < 2 * concurrent
                        and status['served'] == len(crowd.alive)
                        and status['released'] >= len(crowd.gone) - crowd.returns
                        - crowd.never_served())
    return result


def _verdict(crowd, end_step, seed, profile, origin, check_agents):
    """Compare what was sent with what came back, and each fix with its stream."""
    from gps_error_ros.model.geodesy import difference
    from gps_error_ros.model.profiles import load_profile
    from gps_error_ros.model.streams import agent_key
    missing = unexpected = 0
    missing_by_agent, unexpected_by_agent = {}, {}
    for name, steps in crowd.sent.items():
        got = set(crowd.fixes.get(name, {}))
        # from the first fix of each life on (see Driver.wait_for)
        lives = crowd.lives[name]
        firsts = [min((k for k in got if a <= k <= b), default=b + 1) for a, b in lives]
        want = {k for k in steps if k < end_step and (name, k) not in crowd.last
                and any(f <= k <= b for f, (_, b) in zip(firsts, lives))}
        crowd.unseen += sum(len([k for k in steps if a <= k < f])
                            for f, (a, _) in zip(firsts, lives))
        missing += len(want - got)
        if want - got:
            missing_by_agent[name] = {'steps': sorted(want - got), 'lives': lives,
                                      'came_back': name in crowd.returned}
        # the engine's rules (sim/engine.py): truth held up to max_pose_age
        # (3) steps after a pause or departure, and interpolated between two
        # samples at most max(2, 2 x max_pose_age) = 6 s apart (an agent that
        # comes back before the node released it)
        sent = sorted(set(steps))
        allowed = set(sent) | {k + d for k in sent for d in range(1, MAX_POSE_AGE_S + 1)}
        allowed |= {k for a, b in zip(sent, sent[1:]) if b - a <= MAX_GAP_S
                    for k in range(a + 1, b)}
        extra = sorted(got - allowed)
        unexpected += len(extra)
        if extra:
            unexpected_by_agent[name] = {'steps': extra, 'lives': crowd.lives[name]}
    model = load_profile(profile).model()
    # the agents that came back first, then the others, up to check_agents
    names = sorted(crowd.fixes, key=lambda n: (n not in crowd.returned, n))[:check_agents]
    keys = np.array([agent_key(seed, n) for n in names], dtype=np.uint64)
    expected = model.simulate(keys, end_step - T0 + 1, start=T0)
    worst, off_stream = 0.0, {}
    for j, name in enumerate(names):
        box = crowd.fixes[name]
        if not box:
            continue
        steps = np.array(sorted(box))
        lat = np.array([box[k][0] for k in steps])
        lon = np.array([box[k][1] for k in steps])
        n, e = difference(lat, lon, *origin)
        got = np.stack([n, e], axis=1)
        diff = np.abs(got - expected[steps - T0, j]).max(axis=1)
        worst = max(worst, float(diff.max()))
        off = diff > STREAM_TOLERANCE_M
        if off.any():               # which steps, and in which life of the agent
            off_stream[name] = {'steps': steps[off].tolist()[:20],
                                'diff_m': np.round(diff[off], 3).tolist()[:20],
                                'lives': crowd.lives[name],
                                'came_back': name in crowd.returned}
    return {'agents_ever': crowd.count, 'returns': crowd.returns,
            'fixes_received': sum(len(b) for b in crowd.fixes.values()),
            'missing_by_agent': missing_by_agent, 'unexpected_by_agent': unexpected_by_agent,
            'poses_before_match': crowd.unseen,
            'departures': len(crowd.gone), 'missing': missing, 'unexpected': unexpected,
            'duplicates': crowd.dup, 'agents_checked': len(names),
            'max_error_diff_m': worst, 'off_stream_by_agent': off_stream}


def main(argv=None):
    """Run the churn soak from the command line; exit 1 when a check fails."""
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--concurrent', type=int, default=50)
    p.add_argument('--hours', type=float, default=2.0, help='simulated hours')
    p.add_argument('--life-s', type=int, nargs=2, default=(60, 600),
                   help='an agent lives uniformly this many simulated seconds')
    p.add_argument('--return-every', type=int, default=5)
    p.add_argument('--sample-s', type=int, default=300)
    p.add_argument('--warmup-s', type=int, default=900)
    p.add_argument('--rss-growth-mb', type=float, default=20.0)
    p.add_argument('--check-agents', type=int, default=300)
    p.add_argument('--max-speed', type=float, default=15.0)
    p.add_argument('--json', help='write the result here')
    args = p.parse_args(argv)
    r = run(args.concurrent, int(args.hours * 3600), tuple(args.life_s), args.return_every,
            args.sample_s, args.warmup_s, args.rss_growth_mb, args.check_agents,
            max_speed=args.max_speed)
    print(f'churn soak: {r["agents_ever"]} agents ({r["returns"]} returns, '
          f'{r["departures"]} departures, about {r["concurrent"]} at a time) over '
          f'{r["simulated_s"] / 3600:g} simulated h in {r["wall_s"]:.0f} s '
          f'(x{r["speed_x_real_time"]:.1f}): missing {r["missing"]}, unexpected '
          f'{r["unexpected"]}, duplicates {r["duplicates"]} (poses sent before the node '
          f'matched, not counted: {r["poses_before_match"]}); errors of '
          f'{r["agents_checked"]} agents against their streams: max diff '
          f'{r["max_error_diff_m"]:.1e} m; RSS {r["rss_mb_samples"][:1]} -> '
          f'{r["rss_mb_samples"][-1:]} MB (growth {r["rss_growth_mb"]:.1f} MB); '
          f'served at most {r["served_max"]}, at the end {r["served_at_end"]} of '
          f'{r["alive_at_end"]} alive, released {r["released"]} (lives never served: '
          f'{r["lives_never_served"]}): '
          f'{"PASSED" if r["passed"] else "FAILED"}')
    for line in r['node_summary']:
        print(f'  node {line.strip()}')
    if args.json:
        Path(args.json).write_text(json.dumps(r, indent=1))
    return 0 if r['passed'] else 1


if __name__ == '__main__':
    sys.exit(main())
