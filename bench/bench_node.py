"""
Node benchmark: one gps_error_node serving 1, 100, 1,000 and 5,000 agents.

Three processes per case: this driver publishes /clock and one pose per agent
per simulated second; the node (a separate process) steps all agents; a
counter process subscribes to every agent's fix topic and counts fixes keyed
by (agent, stamp). Reported: the node's CPU seconds per simulated hour (from
/proc, all its threads), the fraction of one core that means at real time,
its wall time per timer tick (from its own shutdown summary), its resident
memory, and fixes published against fixes received. Fixes are reliable (the
node's default) in every case, and best effort in a second 1,000-agent case
(--fix-reliability; the counter's subscriptions then are best effort too).

The floor (``floor_node.py``): at 1,000 and 5,000 agents each case runs
three times in the same run: the node with ``agents``, the node with
``agent_pattern`` (the agents found in the graph), and a bare rclpy process
with the same subscriptions and publishers that publishes a pre-serialized
fix per truth message (best effort paced as the node paces it). The node's
CPU is reported as a ratio to the floor's; with ``--repeats R`` each case's
modes run R times interleaved and the median and range of the ratios are
printed (one run per mode puts a ratio no closer than about +-0.2).
At 1,000 agents the node also runs with ``covariance_mode: conditional``
(a covariance per fix) and ``covariance_mode: reported`` (DS5 with a
``reported_accuracy`` section whose radius follows the predictive scale, so
both the conditional covariance and the stated radius are computed per
fix), each reported as a ratio to the stationary run.
"""

import argparse
import json
import os
from pathlib import Path
import re
import signal
import statistics
import struct
import subprocess
import sys
import tempfile
import time

NS = 1_000_000_000
CASES = ((1, 600, 50.0, 'reliable'), (100, 600, 20.0, 'reliable'),
         (1000, 300, 5.0, 'reliable'), (1000, 300, 5.0, 'best_effort'),
         (5000, 120, 2.0, 'reliable'))
#: crowd sizes run also with agent_pattern and as the floor
FLOOR_SIZES = (1000, 5000)
MODES = ('agents', 'conditional', 'reported', 'agent_pattern', 'floor')
#: crowd sizes run also with covariance_mode conditional and reported (per-fix covariance)
CONDITIONAL_SIZES = (1000,)
#: the stated accuracy of the reported runs (follow != 0: the costlier path)
REPORTED = ('reported_accuracy: {source: accuracy, median_m: 3.0, follow: 0.01, phi: 0.9, '
            'sigma_log: 0.05, resolution_m: 1.0, scale_m: 0.0}\n')


#: The shutdown summary of the node and of the floor (``bench/floor_node.py``): published,
#: skipped without truth, out of order, stamped in the future, mean and max ms per tick.
SUMMARY = re.compile(r'(\d+) NavSatFix published \(\d+ with a position, \d+ NO_FIX\), '
                     r'\d+ steps in an outage, \d+ non-finite fixes refused, '
                     r'(\d+) skipped without truth, (\d+) truth '
                     r'messages out of order, (\d+) stamped in the future.*wall time per '
                     r'tick ([\d.]+) ms mean, ([\d.]+) ms max')


def _stat_cpu_s(path):
    """Return (name, user + system CPU seconds) from a /proc .../stat file."""
    with open(path) as f:
        head, tail = f.read().rsplit(')', 1)
    fields = tail.split()
    return head.split('(', 1)[1], (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def proc_cpu_s(pid):
    return _stat_cpu_s(f'/proc/{pid}/stat')[1]


def thread_cpu_s(pid):
    """Return {thread name: CPU seconds} summed over the process's threads."""
    out = {}
    for tid in os.listdir(f'/proc/{pid}/task'):
        try:
            name, cpu = _stat_cpu_s(f'/proc/{pid}/task/{tid}/stat')
        except OSError:         # the thread has exited
            continue
        name = re.sub(r'\d+$', '', name) or '?'
        out[name] = out.get(name, 0.0) + cpu
    return out


def proc_mem_mb(pid):
    out = {}
    with open(f'/proc/{pid}/status') as f:
        for line in f:
            if line.startswith(('VmRSS', 'VmHWM')):
                k, v = line.split(':')
                out[k] = int(v.split()[0]) / 1024
    return out


def _ranges(indices):
    """Compress sorted integers to [first, last] runs."""
    runs = []
    for i in indices:
        if runs and runs[-1][1] == i - 1:
            runs[-1][1] = i
        else:
            runs.append([i, i])
    return runs


def ready_file(count_file):
    """Return the file the counter creates once every fix topic has a publisher."""
    return Path(f'{count_file}.ready')


def counter_main(n, out_path, reliability):
    """Count fixes per (agent, stamp) on n topics, draining on a timer."""
    import rclpy
    from rclpy.callback_groups import CallbackGroup
    from rclpy.executors import ExternalShutdownException
    from rclpy.node import Node
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import NavSatFix

    class Never(CallbackGroup):
        def can_execute(self, entity):
            return False

        def beginning_execution(self, entity):
            return False

        def ending_execution(self, entity):
            pass

    rclpy.init()
    node = Node('fix_counter')
    group = Never()
    qos = QoSProfile(depth=100, reliability={
        'reliable': ReliabilityPolicy.RELIABLE,
        'best_effort': ReliabilityPolicy.BEST_EFFORT}[reliability])
    subs = [node.create_subscription(NavSatFix, f'/bench/a{i}/fix', lambda m: None,
                                     qos, raw=True, callback_group=group)
            for i in range(n)]
    seen, total, matched = set(), [0], [False]

    def drain():
        if not matched[0] and all(sub.get_publisher_count() > 0 for sub in subs):
            matched[0] = True
            ready_file(out_path).touch()    # the driver starts once every fix topic is matched
        for i, sub in enumerate(subs):
            while True:
                with sub.handle:
                    taken = sub.handle.take_message(sub.msg_type, True)
                if taken is None:
                    break
                sec, nsec = struct.unpack_from('<iI', taken[0], 4)
                seen.add((i, sec * NS + nsec))
                total[0] += 1

    node.create_timer(max(0.02, 4e-5 * n), drain)     # ~0.2 s at 5,000 topics
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        drain()
        agents_at = {}
        for i, stamp in seen:
            agents_at.setdefault(stamp, set()).add(i)
        per_stamp = {stamp: len(got) for stamp, got in agents_at.items()}
        # agents without a fix at each incomplete stamp, as index ranges
        missing = {stamp: _ranges(sorted(set(range(n)) - got))
                   for stamp, got in agents_at.items() if len(got) < n}
        Path(out_path).write_text(json.dumps({'unique': len(seen), 'total': total[0],
                                              'per_stamp': per_stamp,
                                              'missing_agents': missing}))
        rclpy.try_shutdown()


def run_case(n, sim_s, speed, workdir, reliability='reliable', mode='agents'):
    params = Path(workdir, f'params{n}_{mode}.yaml')
    names = ', '.join(f'"a{i}"' for i in range(n))
    serve = 'agent_pattern: /bench/*/pose' if mode == 'agent_pattern' else \
        f'agents: [{names}]'
    profile = 'DS5'
    if mode in ('conditional', 'reported'):
        serve += f'\n    covariance_mode: {mode}'
    if mode == 'reported':
        from gps_error_ros.model.profiles import builtin_dir
        profile = Path(workdir, 'reported.yaml')
        profile.write_text((builtin_dir() / 'DS5.yaml').read_text() + REPORTED)
    params.write_text('/**:\n  ros__parameters:\n    use_sim_time: true\n'
                      '    datum: [40.75, -73.99, 0.0]\n    seed: 1\n'
                      f'    profile: {profile}\n    fix_reliability: {reliability}\n'
                      f'    {serve}\n')
    count_file = Path(workdir, f'count{n}_{reliability}_{mode}.json')    # one per case
    exe = Path(sys.executable).with_name('gps_error_node')
    prof = os.environ.get('BENCH_NODE_PROFILE')     # cProfile output, optional
    pre = [sys.executable, '-m', 'cProfile', '-o', prof, '-m',
           'gps_error_ros.ros.error_node'] if prof else [str(exe)]
    args = ['--ros-args', '-r', '__ns:=/bench', '--params-file', str(params)]
    if mode == 'floor':
        pre = [sys.executable, str(Path(__file__).with_name('floor_node.py')), str(n),
               reliability]
        args = ['--ros-args', '-r', '__ns:=/bench']
    log = open(Path(workdir, f'node{n}_{reliability}_{mode}.log'), 'w+')   # not a pipe:
    node = subprocess.Popen(pre + args,                 # a full one would block the node
                            stdout=log, stderr=subprocess.STDOUT, text=True)
    node.log = log
    counter = subprocess.Popen([sys.executable, __file__, '--counter', str(n),
                                str(count_file), reliability])
    try:
        return dict(_drive(n, sim_s, speed, node, counter, count_file),
                    fix_reliability=reliability, mode=mode)
    finally:
        for proc in (node, counter):
            if proc.poll() is None:
                proc.kill()
                proc.wait()


def _drive(n, sim_s, speed, node, counter, count_file):
    import rclpy
    from geometry_msgs.msg import PoseStamped
    from rclpy.node import Node
    from rclpy.qos import QoSProfile
    from rosgraph_msgs.msg import Clock

    from gps_error_ros.ros.conversions import to_stamp

    rclpy.init()
    drv = Node('bench_driver')
    qos = QoSProfile(depth=10)
    clock = drv.create_publisher(Clock, '/clock', qos)
    pubs = [drv.create_publisher(PoseStamped, f'/bench/a{i}/pose', qos) for i in range(n)]
    deadline = time.monotonic() + 60 + 0.1 * n      # 10k endpoints take a while
    ready = ready_file(count_file)
    while any(p.get_subscription_count() == 0 for p in pubs) or not ready.exists():
        if time.monotonic() > deadline or node.poll() is not None or counter.poll() is not None:
            raise RuntimeError('node or counter did not come up')
        time.sleep(0.1)
    time.sleep(2.0)
    msg = PoseStamped()
    msg.header.frame_id = 'map'
    msg.pose.orientation.w = 1.0
    t0 = 1000
    cpu0 = mem0 = None
    wall0 = time.monotonic()
    for k in range(sim_s + 1):
        stamp = to_stamp((t0 + k) * NS)
        msg.header.stamp = stamp
        for c in range(0, n, 500):
            for i in range(c, min(n, c + 500)):
                msg.pose.position.x = float(i)
                pubs[i].publish(msg)
            time.sleep(0.001)
        clock.publish(Clock(clock=stamp))
        if k == 10:                                  # after warm-up
            cpu0, wall0 = proc_cpu_s(node.pid), time.monotonic()
            threads0 = thread_cpu_s(node.pid)
            mem0 = proc_mem_mb(node.pid)
        lag = (k + 1) / speed - (time.monotonic() - wall0) if k >= 10 else 1.0 / speed
        time.sleep(max(0.0, lag if k >= 10 else 1.0 / speed))
    time.sleep(1.5)
    cpu1, wall1 = proc_cpu_s(node.pid), time.monotonic()
    threads1 = thread_cpu_s(node.pid)
    mem1 = proc_mem_mb(node.pid)
    clock.publish(Clock(clock=to_stamp((t0 + sim_s + 1) * NS)))
    time.sleep(2.0)
    drv.destroy_node()
    rclpy.try_shutdown()
    stop0 = time.monotonic()
    node.send_signal(signal.SIGINT)
    node.wait(timeout=300)
    stop_s = time.monotonic() - stop0
    node.log.seek(0)
    out = node.log.read()
    counter.send_signal(signal.SIGINT)
    # an overloaded run (5,000 agents) leaves the counter a backlog to drain before it writes
    counter.wait(timeout=300)
    counts = json.loads(count_file.read_text())
    m = SUMMARY.search(out)
    if not m:
        raise RuntimeError(f'no summary from the node:\n{out[-2000:]}')
    published = int(m.group(1))
    measured_sim = sim_s - 10
    got = [counts['per_stamp'].get(str((t0 + k) * NS), 0) for k in range(sim_s + 1)]
    short = {k: n - c for k, c in enumerate(got) if c < n}
    cpu = cpu1 - cpu0
    return {
        'agents': n, 'simulated_s': measured_sim, 'speed_x_real_time': speed,
        'node_cpu_s_per_sim_hour': cpu / measured_sim * 3600,
        'core_fraction_at_real_time': cpu / measured_sim,
        'tick_ms_mean': float(m.group(5)), 'tick_ms_max': float(m.group(6)),
        'core_fraction_by_thread': {
            k: (v - threads0.get(k, 0.0)) / measured_sim for k, v in threads1.items()
            if v - threads0.get(k, 0.0) > 0},
        'rss_mb_after_warmup': mem0['VmRSS'], 'rss_mb_end': mem1['VmRSS'],
        'peak_rss_mb': mem1['VmHWM'],
        'agent_steps_with_truth': n * (sim_s + 1),
        'fixes_published': published, 'skipped_without_truth': int(m.group(2)),
        'truth_out_of_order': int(m.group(3)), 'truth_in_future': int(m.group(4)),
        'fixes_received_unique': counts['unique'],
        'received_fraction': counts['unique'] / published if published else 0.0,
        'steps_short_of_fixes': short,      # simulated second -> fixes not received
        'agents_missing_by_step': {        # simulated second -> [first, last] agent runs
            int(stamp) // NS - t0: runs for stamp, runs in counts['missing_agents'].items()},
        'wall_s': wall1 - wall0, 'stop_s': stop_s,
    }


def _print_ratios(rows, n, reliability, repeat):
    """Print the node's CPU against the floor's, measured in this run."""
    same = {r['mode']: r for r in rows if r['agents'] == n and
            r['fix_reliability'] == reliability and r['repeat'] == repeat}
    floor = same['floor']['core_fraction_at_real_time']
    for mode in ('agents', 'agent_pattern'):
        if mode in same and floor > 0:
            ratio = same[mode]['core_fraction_at_real_time'] / floor
            same[mode]['cpu_ratio_to_floor'] = ratio
            print(f'       {mode}: {ratio:.2f}x the floor\'s CPU '
                  f'({100 * same[mode]["core_fraction_at_real_time"]:.2f} % against '
                  f'{100 * floor:.2f} % of a core at 1x)', flush=True)


def _print_repeats(rows):
    """Print each node mode's ratio to the floor over the repeats: median, range."""
    ratios = {}
    for r in rows:
        if 'cpu_ratio_to_floor' in r:
            key = (r['agents'], r['fix_reliability'], r['mode'])
            ratios.setdefault(key, []).append(r['cpu_ratio_to_floor'])
    for (n, reliability, mode), got in sorted(ratios.items()):
        got.sort()
        if len(got) > 1:
            print(f'{n:>5} agents, {reliability} fixes, {mode}: ratio to the floor over '
                  f'{len(got)} repeats: median {statistics.median(got):.2f}, '
                  f'range {got[0]:.2f}-{got[-1]:.2f}', flush=True)


def _print_conditional(rows, n, reliability, mode):
    """Print the per-fix covariance's CPU against the stationary one, same run."""
    same = {r['mode']: r for r in rows
            if r['agents'] == n and r['fix_reliability'] == reliability}
    if 'agents' in same:
        base = same['agents']['core_fraction_at_real_time']
        cond = same[mode]['core_fraction_at_real_time']
        same[mode]['cpu_ratio_to_stationary'] = cond / base
        print(f'       covariance_mode {mode}: {cond / base:.2f}x the stationary '
              f'node\'s CPU ({100 * cond:.2f} % against {100 * base:.2f} %)', flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--counter', nargs=3, metavar=('N', 'OUT', 'RELIABILITY'),
                   help=argparse.SUPPRESS)
    p.add_argument('--agents', type=int, nargs='*', help='only these crowd sizes')
    p.add_argument('--json', help='write the figures here')
    p.add_argument('--fix-reliability', choices=('reliable', 'best_effort'),
                   help='QoS of the fixes (the node\'s fix_reliability parameter); '
                        'default: the cases\' own (all reliable, and 1,000 agents '
                        'also best_effort), or reliable with --agents')
    p.add_argument('--modes', nargs='+', choices=MODES, default=list(MODES),
                   help='which runs (default all): agents, conditional and reported '
                        '(1,000 agents, covariance_mode conditional / reported), '
                        'agent_pattern and floor (1,000 and 5,000 agents)')
    p.add_argument('--no-floor', action='store_true',
                   help='skip the agent_pattern and floor runs of the 1,000- and '
                        '5,000-agent cases')
    p.add_argument('--speed', type=float, default=None,
                   help='simulated seconds per wall second for every case '
                        '(default: per case, 50x for 1 agent down to 2x for 5,000)')
    p.add_argument('--repeats', type=int, default=1,
                   help='run each case this many times, its modes interleaved '
                        '(node, agent_pattern, floor, node, ...), and print the median '
                        'and range of the ratios to the floor')
    args = p.parse_args()
    if args.counter:
        counter_main(int(args.counter[0]), args.counter[1], args.counter[2])
        return
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    rows = []
    with tempfile.TemporaryDirectory() as work:
        if args.agents:         # each size asked for, once, with the QoS asked for
            cases = [(n, sim_s, speed, args.fix_reliability or 'reliable')
                     for n, sim_s, speed, qos in CASES
                     if n in args.agents and qos == 'reliable']
        else:
            cases = [c for c in CASES
                     if args.fix_reliability in (None, c[3])]
        runs = [(c, rep, mode) for c in cases for rep in range(args.repeats)
                for mode in MODES if mode in args.modes and (
            mode == 'agents' or (mode in ('conditional', 'reported')
                                 and c[0] in CONDITIONAL_SIZES)
            or (c[0] in FLOOR_SIZES and not args.no_floor))]
        for (n, sim_s, speed, reliability), rep, mode in runs:
            speed = args.speed or speed
            r = dict(run_case(n, sim_s, speed, work, reliability, mode), repeat=rep)
            rows.append(r)
            who = {'agents': 'node', 'agent_pattern': 'node (agent_pattern)',
                   'conditional': 'node (covariance_mode conditional)',
                   'reported': 'node (covariance_mode reported)',
                   'floor': 'floor'}[mode]
            print(f'{n:>5} agents, {reliability} fixes: {who} '
                  f'{r["node_cpu_s_per_sim_hour"]:7.1f} CPU-s per simulated hour '
                  f'({100 * r["core_fraction_at_real_time"]:.2f} % of a core at 1x), '
                  f'tick {r["tick_ms_mean"]:.2f} ms mean / {r["tick_ms_max"]:.1f} ms max, '
                  f'RSS {r["rss_mb_end"]:.0f} MB, '
                  f'fixes published {r["fixes_published"]} for '
                  f'{r["agent_steps_with_truth"]} agent-steps with truth, received '
                  f'{r["fixes_received_unique"]}/{r["fixes_published"]} '
                  f'({100 * r["received_fraction"]:.2f} %); node skipped '
                  f'{r["skipped_without_truth"]} without truth, dropped '
                  f'{r["truth_out_of_order"]} out of order and {r["truth_in_future"]} '
                  f'stamped in the future; stopped {r["stop_s"]:.1f} s after SIGINT',
                  flush=True)
            if r['steps_short_of_fixes']:
                print('       steps short of fixes (simulated s: missing): ' + ', '.join(
                    f'{k}: {v}' for k, v in sorted(r['steps_short_of_fixes'].items())))
            threads = sorted(r['core_fraction_by_thread'].items(), key=lambda kv: -kv[1])
            print('       node threads (% of a core at 1x): ' + ', '.join(
                f'{k} {100 * v:.2f}' for k, v in threads if v >= 0.0005), flush=True)
            if mode == 'floor':
                _print_ratios(rows, n, reliability, rep)
            if mode in ('conditional', 'reported'):
                _print_conditional(rows, n, reliability, mode)
    _print_repeats(rows)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))


if __name__ == '__main__':
    main()
