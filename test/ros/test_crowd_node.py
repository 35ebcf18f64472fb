"""One error node serving a crowd; sharding over processes gives the same fixes."""

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import NavSatFix

from gps_error_ros.model.profiles import load_profile
from ros_harness import DATUM_ARG, NodeProcess, NS, Peer, pose_msg, stamp_ns, unique_ns

pytestmark = pytest.mark.integration
AGENTS = [f'ped{i}' for i in range(6)]
PROFILES = ['DS1', 'DS5'] * 3
T0 = 2000
# The driver sends /clock k+1 as soon as the fixes of k-1 are in, so a pose
# may still be in flight one step after its instant: max_pose_age must cover
# that (README, "Truth"), or a step is held on the previous pose.
MAX_AGE = 3.0


def crowd_node(ns, agents, profiles, extra=()):
    args = ['--ros-args', '-r', f'__ns:={ns}', '-p', 'use_sim_time:=true',
            '-p', DATUM_ARG, '-p', 'seed:=99', '-p', f'max_pose_age:={MAX_AGE}',
            '-p', 'agents:=[' + ','.join(f'"{a}"' for a in agents) + ']',
            '-p', 'agent_profiles:=[' + ','.join(f'"{p}"' for p in profiles) + ']']
    for p in extra:
        args += ['-p', p]
    return NodeProcess(args)


def shard_topics(peer, shards):
    """
    Return pose publishers and fix boxes keyed (namespace, agent) for ``shards``.

    ``shards`` is ((namespace, agents), ...); returns once every node has
    subscribed to its poses and publishes its fixes.
    """
    pubs, boxes = {}, {}
    for ns, agents in shards:
        for a in agents:
            pubs[ns, a] = peer.publisher(PoseStamped, f'{ns}/{a}/pose')
            boxes[ns, a] = peer.collect(NavSatFix, f'{ns}/{a}/fix')
    assert peer.spin_until(lambda: all(p.get_subscription_count() > 0 for p in pubs.values())
                           and all(peer.node.count_publishers(f'{ns}/{a}/fix') > 0
                                   for ns, a in boxes), 30)
    return pubs, boxes


def test_crowd_sharded_over_two_processes_gives_identical_fixes():
    whole, half_a, half_b = unique_ns(), unique_ns(), unique_ns()
    nodes = [crowd_node(whole, AGENTS, PROFILES),
             crowd_node(half_a, AGENTS[:3], PROFILES[:3]),
             crowd_node(half_b, AGENTS[3:], PROFILES[3:])]
    peer = Peer()
    try:
        pubs, boxes = shard_topics(peer, ((whole, AGENTS), (half_a, AGENTS[:3]),
                                          (half_b, AGENTS[3:])))
        # the node drains its truth subscriptions itself, outside the executor;
        # they are still its own in the ROS graph
        graph = {}

        def listed():       # node names reach the graph a little after endpoints
            try:
                graph.update(peer.node.get_subscriber_names_and_types_by_node(
                    'gps_error_node', whole))
            except RuntimeError:    # rclpy: the node is not (yet) known by name
                return False
            return all(graph.get(f'{whole}/{a}/pose') == ['geometry_msgs/msg/PoseStamped']
                       for a in AGENTS)
        assert peer.spin_until(listed, 10), graph
        peer.spin_for(0.5)
        n_steps = 40
        pause = range(T0 + 10, T0 + 20)          # ped1 of the whole crowd goes quiet
        for k in range(T0, T0 + n_steps + 2):
            for (ns, a), pub in pubs.items():
                if ns == whole and a == 'ped1' and k in pause:
                    continue
                pub.publish(pose_msg(k * NS, 3.0 * (k - T0), 1.0))
            peer.set_clock(k * NS)
            want = (k - 1) * NS
            peer.spin_until(lambda: all(box and stamp_ns(box[-1].header.stamp) >= want
                                        for (ns, a), box in boxes.items()
                                        if not (ns == whole and a == 'ped1')), 5)
        peer.spin_for(0.5)
        for node in nodes:
            rc, out = node.stop()
            assert rc == 0, out
        # the start-up line names every profile and how many agents it serves
        log = nodes[0].stop()[1]
        assert 'profile DS1 (3 agents)' in log and 'profile DS5 (3 agents)' in log, log
    finally:
        for node in nodes:
            node.stop()
        peer.destroy()

    def series(ns, a):
        return {stamp_ns(m.header.stamp): (m.latitude, m.longitude, tuple(m.position_covariance))
                for m in boxes[ns, a]}

    for i, a in enumerate(AGENTS):
        shard = half_a if i < 3 else half_b
        got, ref = series(whole, a), series(shard, a)
        assert len(ref) >= n_steps
        common = sorted(set(got) & set(ref))
        if a == 'ped1':
            # inside the pause the whole crowd's node holds the last pose
            # (a different truth); the error stream must agree outside it
            common = [t for t in common if not (T0 + 10) * NS <= t < (T0 + 20) * NS]
        assert common and all(got[t] == ref[t] for t in common), a   # byte-identical
        if a == 'ped1':
            missing = sorted(set(ref) - set(got))
            # quiet for 10 s: held up to max_pose_age (3 s), then no fixes
            # (the 11 s gap is too long to interpolate across)
            assert len(missing) >= 6 and all((T0 + 11) * NS <= t < (T0 + 21) * NS
                                             for t in missing)
            assert max(got) > (T0 + 25) * NS          # resumed, on the same stream
        else:
            assert got.keys() == ref.keys()
        sd = load_profile(PROFILES[i]).model(about_truth=True).stationary_sd   # rms
        assert got[common[0]][2][0] == pytest.approx(sd[1] ** 2)


def test_best_effort_fixes_reach_every_agent_in_paced_bursts():
    """fix_reliability best_effort: sensor-data QoS, bursts of 100, none lost."""
    ns, n, steps = unique_ns(), 250, 4          # 250 agents: bursts of 100, 100, 50
    agents = [f'p{i}' for i in range(n)]
    node = NodeProcess([
        '--ros-args', '-r', f'__ns:={ns}', '-p', 'use_sim_time:=true', '-p', DATUM_ARG,
        '-p', 'seed:=5', '-p', f'max_pose_age:={MAX_AGE}', '-p', 'fix_reliability:=best_effort',
        '-p', 'agents:=[' + ','.join(f'"{a}"' for a in agents) + ']'])
    peer = Peer()
    best_effort = QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT)
    try:
        pubs = [peer.publisher(PoseStamped, f'{ns}/{a}/pose') for a in agents]
        boxes = [peer.collect(NavSatFix, f'{ns}/{a}/fix', best_effort) for a in agents]
        reliable_box = []           # (collect() would share the topic's list)
        peer.node.create_subscription(NavSatFix, f'{ns}/{agents[0]}/fix',
                                      reliable_box.append, QoSProfile(depth=100))
        assert peer.spin_until(lambda: all(p.get_subscription_count() > 0 for p in pubs)
                               and all(peer.node.count_publishers(f'{ns}/{a}/fix') > 0
                                       for a in agents), 60)
        info = peer.node.get_publishers_info_by_topic(f'{ns}/{agents[0]}/fix')
        assert [i.qos_profile.reliability for i in info] == [ReliabilityPolicy.BEST_EFFORT]
        peer.spin_for(1.0)
        for k in range(T0, T0 + steps + 2):
            for pub in pubs:
                pub.publish(pose_msg(k * NS, 1.0, 2.0))
            peer.spin_for(0.05)
            peer.set_clock(k * NS)
            want = (k - 1) * NS
            peer.spin_until(lambda: all(box and stamp_ns(box[-1].header.stamp) >= want
                                        for box in boxes), 10)
        peer.spin_for(0.5)
        rc, out = node.stop()
        assert rc == 0, out
    finally:
        node.stop()
        peer.destroy()
    wanted = {k * NS for k in range(T0, T0 + steps + 1)}
    short = {a: sorted(wanted - {stamp_ns(m.header.stamp) for m in box})
             for a, box in zip(agents, boxes)}
    assert not any(short.values()), {a: s for a, s in short.items() if s}
    # a reliable subscriber does not match a best-effort publisher (ROS QoS rules)
    assert reliable_box == []


@pytest.mark.parametrize('choice, policy', [(None, ReliabilityPolicy.BEST_EFFORT),
                                            ('reliable', ReliabilityPolicy.RELIABLE)])
def test_truth_subscriptions_have_the_reliability_asked_for(choice, policy):
    """input_reliability: the agents' truth subscriptions are best effort or reliable."""
    ns = unique_ns()
    args = ['--ros-args', '-r', f'__ns:={ns}', '-p', DATUM_ARG, '-p', 'agents:=["a","b"]']
    node = NodeProcess(args + (['-p', f'input_reliability:={choice}'] if choice else []))
    peer = Peer()
    try:
        topics = [f'{ns}/a/pose', f'{ns}/b/pose']
        assert peer.spin_until(lambda: all(peer.node.count_subscribers(t) for t in topics), 30)
        for t in topics:
            info = peer.node.get_subscriptions_info_by_topic(t)
            assert [i.qos_profile.reliability for i in info] == [policy], t
        rc, out = node.stop()
        assert rc == 0, out
    finally:
        node.stop()
        peer.destroy()


def test_crowd_parameter_errors():
    for params, hint in (
            (['agents:=["a","a"]'], 'duplicate'),
            (['agents:=["1bad"]'], 'invalid agent name'),
            (['agents:=["a","b"]', 'agent_profiles:=["DS1"]'], 'one per agent'),
            (['agents:=["a"]', 'agent_profiles:=["DS4"]'], 'no published fit'),
            (['agents:=["a"]', 'fix_reliability:=lossy'], "expected one of ['reliable'"),
            (['agents:=["a"]', 'input_reliability:=lossy'], "expected one of ['best_effort'")):
        args = ['--ros-args', '-r', f'__ns:={unique_ns()}', '-p', DATUM_ARG]
        for p in params:
            args += ['-p', p]
        rc, out = NodeProcess(args).wait_exit()
        assert rc == 2 and hint in out, out


def _cycle_profile(tmp_path, population=False):
    """
    Write DS7 with the periodic effect (8-step cycle), variance regimes, outliers, failures.

    ``population``: with a population section too (a wandering Student-t bias, a
    spread of scales) and a failure rate of each agent's own.
    """
    import yaml
    from gps_error_ros.model.profiles import builtin_dir
    raw = yaml.safe_load((builtin_dir() / 'DS7.yaml').read_text())
    off = np.array([[0.9, -0.4], [-0.3, 0.2], [0.0, 0.1], [-0.6, 0.1]] * 2)
    raw['effects'] = {
        'periodic': {'period_steps': 8, 'scales': [1.8, 0.6, 0.7, 0.8] * 2,
                     'offsets': (off - off.mean(axis=0)).round(6).tolist()},
        'variance_regimes': {'scales': [1.0, 2.0], 'transition': [[0.9, 0.1], [0.2, 0.8]]},
        # frequent jumps, so that 30 steps of two agents hold several
        'outliers': {'rate': 0.15, 'mean_steps': 2.0, 'sigma_m': 6.0}}
    raw['gross_failures'] = {'rate': 0.1, 'sizes_m': [60.0, 400.0, 9000.0]}
    if population:
        raw['population'] = {'bias_sd_m': [4.0, 2.5], 'scale_sd_log': 0.5,
                             'bias_time_constant_s': 20.0, 'bias_dof': 4,
                             'run_bias_sd_m': [3.0, 6.0]}
        # a rate per agent (these two draw below the mean: a higher mean keeps failures in)
        raw['gross_failures'].update(rate=0.3, rate_sd_log=0.5)
    path = tmp_path / 'cycle.yaml'
    path.write_text(yaml.safe_dump(raw))
    return str(path)


@pytest.mark.parametrize('cycle', [False, True, 'population'],
                         ids=['DS7', 'DS7 with a periodic cycle, outliers and failures',
                              'the same with a population section'])
def test_simulate_reproduces_what_the_node_publishes(tmp_path, cycle):
    from gps_error_ros.sim.simulate import simulate_csv
    from gps_error_ros.model.geodesy import difference
    from ros_harness import DATUM

    ns = unique_ns()
    agents = ['walker_a', 'walker_b']
    profile = _cycle_profile(tmp_path, cycle == 'population') if cycle else 'DS7'
    node = NodeProcess(['--ros-args', '-r', f'__ns:={ns}', '-p', 'use_sim_time:=true',
                        '-p', DATUM_ARG, '-p', 'seed:=4', '-p', f'profile:={profile}',
                        '-p', f'max_pose_age:={MAX_AGE}',
                        '-p', 'agents:=["walker_a","walker_b"]'])
    peer = Peer()
    try:
        pubs = {a: peer.publisher(PoseStamped, f'{ns}/{a}/pose') for a in agents}
        boxes = {a: peer.collect(NavSatFix, f'{ns}/{a}/fix') for a in agents}
        assert peer.spin_until(lambda: all(p.get_subscription_count() for p in pubs.values())
                               and all(peer.node.count_publishers(f'{ns}/{a}/fix')
                                       for a in agents), 20)
        peer.spin_for(0.5)
        for k in range(T0, T0 + 31):
            for a in agents:
                pubs[a].publish(pose_msg(k * NS))
            peer.set_clock(k * NS)
            peer.spin_until(lambda: all(b and stamp_ns(b[-1].header.stamp) >= (k - 1) * NS
                                        for b in boxes.values()), 5)
        rc, out = node.stop()
        assert rc == 0, out
    finally:
        node.stop()
        peer.destroy()
    src, dst = tmp_path / 'truth.csv', tmp_path / 'noisy.csv'
    with open(src, 'w') as f:
        f.write('t,agent,truth_lat,truth_lon\n')
        for k in range(T0, T0 + 30):
            for a in agents:
                f.write(f'{k},{a},{DATUM[0]!r},{DATUM[1]!r}\n')
    simulate_csv(src, dst, load_profile(profile).model(), 1.0, 4)
    import csv
    rows = list(csv.DictReader(open(dst)))
    sim = {(r['agent'], int(float(r['t']))): difference(
        float(r['lat']), float(r['lon']), DATUM[0], DATUM[1]) for r in rows}
    compared = 0
    for a in agents:
        for m in boxes[a]:
            k = stamp_ns(m.header.stamp) // NS
            if (a, k) in sim:
                node_err = difference(m.latitude, m.longitude, DATUM[0], DATUM[1])
                np.testing.assert_allclose(np.ravel(node_err), np.ravel(sim[a, k]),
                                           rtol=0, atol=1e-6, err_msg=f'{a} {k}')
                compared += 1
    assert compared >= 55
    if cycle:               # the comparison covered jumps under way, not only clean fixes
        from gps_error_ros.model.streams import agent_key
        model = load_profile(profile).model()
        keys = np.array([agent_key(4, a) for a in agents], dtype=np.uint64)
        state, jumped, failed = model.initial_state(keys, T0), 0, 0

        def field(name):            # the state's field of that name, however wrapped
            [(_, value)] = [(k, v) for k, v in state.arrays().items()
                            if k.split('.')[-1] == name]
            return value
        for k in range(T0 + 1, T0 + 30):
            model.advance(state, keys, k)
            jumped += int(field('in_jump').sum())
            failed += int(np.any(field('offset') != 0.0, axis=1).sum())
        assert jumped >= 5, jumped
        assert failed >= 2, failed
        if cycle == 'population':       # the agents drew biases of metres, and differ
            bias = field('bias')
            assert np.all(np.abs(bias).max(axis=1) > 0.1), bias
            assert field('scale')[0] != field('scale')[1]
            assert np.all(field('bias_factor') != 1.0)     # each run's Student-t factor


def _zone_map(path):
    """Write DS1 west and DS5 east of 41 m east of the datum; return the path."""
    import json
    from ros_harness import DATUM
    border = DATUM[1] + 41.0 / (111320.0 * np.cos(np.radians(DATUM[0])))

    def box(lon0, lon1):
        ring = [[lon0, DATUM[0] - 0.01], [lon1, DATUM[0] - 0.01], [lon1, DATUM[0] + 0.01],
                [lon0, DATUM[0] + 0.01], [lon0, DATUM[0] - 0.01]]
        return {'type': 'Polygon', 'coordinates': [ring]}
    path.write_text(json.dumps({'type': 'FeatureCollection', 'features': [
        {'type': 'Feature', 'properties': {'profile': 'DS1'},
         'geometry': box(DATUM[1] - 0.01, border)},
        {'type': 'Feature', 'properties': {'profile': 'DS5'},
         'geometry': box(border, DATUM[1] + 0.01)}]}))
    return path


@pytest.mark.parametrize('case', ['outages', 'zones', 'velocity', 'reported'])
def test_a_sharded_crowd_gives_the_whole_crowds_fixes(tmp_path, case):
    """
    Outages, zones and velocity are per-agent streams too: two shards give the whole crowd.

    ``outages``: every agent's availability is its own stream (NO_FIX at
    the same steps). ``zones``: the walkers cross from DS1's zone into DS5's
    at about 20 s; the errors follow the zone in every process alike.
    ``velocity``: each agent's reported velocity (``vel``) is the same.
    ``reported``: each fix's stated accuracy (its covariance) is the same.
    """
    from geometry_msgs.msg import TwistWithCovarianceStamped
    import yaml
    from gps_error_ros.model.profiles import builtin_dir
    raw = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    extra = ()
    if case == 'outages':
        raw['availability'] = {'outage_rate': 0.1, 'durations': [[2, 0.5], [4, 0.5]]}
    elif case == 'velocity':
        raw['velocity'] = {'sigma': 0.15, 'phi': 0.7, 'lag_s': 0.4, 'standstill': 0.0}
    elif case == 'reported':
        raw['reported_accuracy'] = {'source': 'accuracy', 'median_m': 4.0, 'follow': 0.0,
                                    'phi': 0.8, 'sigma_log': 0.3, 'resolution_m': 0.5,
                                    'scale_m': 0.0}
        extra = ('covariance_mode:=reported',)
    else:
        extra = (f'zones:={_zone_map(tmp_path / "zones.geojson")}',)
    path = tmp_path / 'profile.yaml'
    path.write_text(yaml.safe_dump(raw))
    agents = AGENTS[:4]
    whole, half_a, half_b = unique_ns(), unique_ns(), unique_ns()
    nodes = [crowd_node(whole, agents, [str(path)] * 4, extra),
             crowd_node(half_a, agents[:2], [str(path)] * 2, extra),
             crowd_node(half_b, agents[2:], [str(path)] * 2, extra)]
    peer = Peer()
    try:
        pubs, boxes = shard_topics(peer, ((whole, agents), (half_a, agents[:2]),
                                          (half_b, agents[2:])))
        vels = {(ns, a): peer.collect(TwistWithCovarianceStamped, f'{ns}/{a}/vel')
                for ns, group in ((whole, agents), (half_a, agents[:2]), (half_b, agents[2:]))
                for a in group} if case == 'velocity' else {}
        assert peer.spin_until(lambda: all(
            any(e.node_namespace == ns for e in peer.node.get_subscriptions_info_by_topic(
                '/clock')) for ns in (whole, half_a, half_b)), 10)
        peer.spin_for(0.5)
        for k in range(T0, T0 + 42):
            for pub in pubs.values():
                pub.publish(pose_msg(k * NS, 2.0 * (k - T0), 1.0))
            peer.set_clock(k * NS)
            want = (k - 1) * NS
            peer.spin_until(lambda: all(box and stamp_ns(box[-1].header.stamp) >= want
                                        for box in boxes.values()), 5)
        peer.spin_for(0.5)
        for node in nodes:
            rc, out = node.stop()
            assert rc == 0, out
    finally:
        for node in nodes:
            node.stop()
        peer.destroy()

    def series(ns, a):
        return {stamp_ns(m.header.stamp): (m.status.status, m.latitude, m.longitude,
                                           m.position_covariance[0])
                for m in boxes[ns, a]}

    outages, covs = 0, set()
    for i, a in enumerate(agents):
        got, ref = series(whole, a), series(half_a if i < 2 else half_b, a)
        assert len(got) >= 40 and got.keys() == ref.keys(), a
        for t in got:
            np.testing.assert_array_equal(got[t], ref[t], err_msg=f'{a} at {t}')  # NaN = NaN
        outages += sum(v[0] == -1 for v in got.values())
        covs |= {round(v[3], 6) for v in got.values()}
    if case == 'outages':
        assert outages > 5                     # there were outages to agree on
    elif case == 'zones':
        assert len(covs) == 2, covs            # the fixes carried both zones' covariance
    elif case == 'reported':
        assert len(covs) >= 4, covs            # stated radii varied, agent by agent
    else:
        for i, a in enumerate(agents):
            def twist(ns):
                return {stamp_ns(m.header.stamp): (m.twist.twist.linear.x, m.twist.twist.linear.y)
                        for m in vels[ns, a]}
            got, ref = twist(whole), twist(half_a if i < 2 else half_b)
            assert len(got) >= 30 and got.keys() == ref.keys(), a
            assert got == ref, a
            assert len({v for v in got.values()}) > 20      # it varies: a stream, not a constant
