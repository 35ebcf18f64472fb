"""
A pedestrian-to-vehicle (P2V) study at one crossing, in ns-3, with the phones' GPS errors.

Pedestrians' phones broadcast personal safety messages over 802.11p;
vehicles driving through the crossing warn of the pedestrians they are
about to hit, from the messages they receive (:mod:`p2v_metrics`). The same
scenario and the same network run once per condition of the phones' GPS:

- ``none``: every phone knows its true position;
- a profile's name (``DS5``, ``phone-suburban-drive``, a YAML path): the
  package's errors (:class:`~gps_error_ros.ns3.source.GpsSource`);
- ``white:PROFILE``: white noise of the same size (the profile's mean and
  per-axis variance, each epoch drawn anew).

Every condition sees the same packets sent and lost: the radio moves with
the truth, and a phone sends whenever it has a fix. What changes is what
the messages say. Run::

    python -m gps_error_ros.ns3.p2v --out p2v_output

Each condition runs in a process of its own (ns-3 has one simulator per
process), as many at a time as ``--jobs``.
"""

import argparse
from concurrent.futures import ProcessPoolExecutor
import json
import multiprocessing
import os
from pathlib import Path
import sys
import time
from typing import Any

import numpy as np

from gps_error_ros.model.profiles import load_profile, Profile, profile_from_dict
from gps_error_ros.ns3 import crossing
from gps_error_ros.ns3.p2v_metrics import delivery, encounters, Rule, score, warnings
from gps_error_ros.ns3.tracks import Tracks
from gps_error_ros.ns3.world import run_world, WorldSpec

DEFAULT_CONDITIONS = ('none', 'white:DS5', 'DS5', 'phone-suburban-drive')
EDGES = np.arange(0.0, 525.0, 25.0)


def white_profile(profile: Profile) -> Profile:
    """Return white noise of ``profile``'s size: its mean and per-axis variance, no memory."""
    model = profile.model()
    sd = np.sqrt(np.diag(np.asarray(model.stationary_cov)))
    mean = np.asarray(model.mean, dtype=float)
    axes = {axis: {'delta': float(mean[k]), 'phi': [0.0], 'sigma_w': float(sd[k])}
            for k, axis in enumerate(('north', 'east'))}
    return profile_from_dict({'schema': 1, 'name': f'white:{profile.name}',
                              'description': f'white noise of the size of {profile.name}',
                              'source': 'gps_error_ros.ns3.p2v.white_profile',
                              'rate_hz': profile.rate_hz, 'axes': axes})


def condition_profile(name: str) -> Profile | None:
    """Return the phones' profile of a condition (None for ``none``)."""
    if name == 'none':
        return None
    if name.startswith('white:'):
        return white_profile(load_profile(name[len('white:'):]))
    return load_profile(name)


def scenario(pedestrians: int, vehicles: int, duration: float,
             seed: int) -> tuple[Tracks, Tracks]:
    """Return the pedestrians' and vehicles' tracks of a run (the same for every condition)."""
    rng = np.random.default_rng(seed)
    return (crossing.pedestrians(pedestrians, duration, rng),
            crossing.vehicles(vehicles, duration, rng))


def _run_condition(args: tuple[str, WorldSpec]) -> dict[str, Any]:
    """Run one condition's world (in a process of its own); return its logs."""
    name, spec = args
    return run_world(spec, condition_profile(name))


def study(spec: WorldSpec, conditions: tuple[str, ...], jobs: int,
          rule: Rule = Rule()) -> dict[str, Any]:
    """Run every condition on ``spec``; return each one's figures and the curves to plot."""
    for name in conditions:
        condition_profile(name)         # a bad name fails before any world runs
    ctx = multiprocessing.get_context('spawn')
    # a fresh process per condition: ns-3 numbers its random streams per process
    with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx, max_tasks_per_child=1) as pool:
        logs = list(pool.map(_run_condition, [(c, spec) for c in conditions]))
    ticks = np.arange(0.0, spec.duration, rule.tick)
    found, cars, vel = encounters(spec.pedestrians, spec.vehicles, ticks, rule)
    out: dict[str, Any] = {'conditions': {}}
    shown = _busiest(found, len(spec.pedestrians.names))
    truth = spec.pedestrians.at(ticks)[shown]
    out['example'] = {'pedestrian': spec.pedestrians.names[shown],
                      'truth_xy': truth[::5].round(3).tolist()}
    for name, log in zip(conditions, logs):
        warned = warnings(log, len(spec.pedestrians.names), cars, vel, ticks, rule)
        sent, got, error = delivery(log, spec.pedestrians, spec.vehicles, EDGES)
        res = score(found, warned, ticks, rule)
        res.update({
            'messages_sent': int(log['tx_time'].size), 'messages_without_fix': log['no_fix'],
            'received_by_vehicles': int(log['rx_time'].size),
            'pdr_sent': sent.tolist(), 'pdr_delivered': got.tolist(),
            'channel_busy': (log['busy'] / spec.duration).tolist(),
            'message_error_m': {'median': float(np.median(error)),
                                'p95': float(np.percentile(error, 95))},
            'wall_s': log['wall_s'],
            'rx_digest': _digest(log),
            'example_xy': _stated(log, shown)})
        out['conditions'][name] = res
    out['pdr_edges_m'] = EDGES.tolist()
    return out


def _busiest(found: list[tuple[int, int, int, int]], n_peds: int) -> int:
    """Return the pedestrian with the most encounters (the figure's example)."""
    counts = np.bincount([j for _, j, _, _ in found], minlength=n_peds)
    return int(np.argmax(counts))


def _stated(log: dict[str, Any], ped: int) -> list[list[float]]:
    """Return the positions pedestrian ``ped``'s messages stated, one per fix."""
    sel = log['tx_node'] == ped
    _, first = np.unique(log['tx_fix_time'][sel], return_index=True)
    xy = np.column_stack([log['tx_x'][sel][first], log['tx_y'][sel][first]])
    return xy.round(3).tolist()


def _digest(log: dict[str, Any]) -> str:
    """Return a digest of which messages were sent and received when (not of what they said)."""
    import hashlib
    h = hashlib.sha256()
    for k in ('tx_node', 'tx_count', 'tx_time', 'rx_node', 'rx_from', 'rx_count', 'rx_time'):
        h.update(np.ascontiguousarray(log[k]).tobytes())
    return h.hexdigest()[:16]


def table(result: dict[str, Any]) -> str:
    """Return the study's figures as a Markdown table, one row per condition."""
    rows = ['| condition | encounters | caught (95 % CI) | lead time median (s) '
            '| warnings | false (95 % CI) | message error median / p95 (m) |',
            '|---|---|---|---|---|---|---|']
    for name, r in result['conditions'].items():
        lo, hi = r['hit_rate_95']
        flo, fhi = r['false_share_95']
        lead = float(np.median(r['lead_s'])) if r['lead_s'] else float('nan')
        share = r['false_warnings'] / r['warnings'] if r['warnings'] else float('nan')
        err = r['message_error_m']
        rows.append(f"| {name} | {r['encounters']} | {r['hit_rate']:.2f} ({lo:.2f}-{hi:.2f}) "
                    f"| {lead:.1f} | {r['warnings']} | {share:.2f} ({flo:.2f}-{fhi:.2f}) "
                    f"| {err['median']:.1f} / {err['p95']:.1f} |")
    return '\n'.join(rows)


def main(argv: list[str] | None = None) -> int:
    """Run the study from the command line; write its figures to ``--out``."""
    p = argparse.ArgumentParser(prog='python -m gps_error_ros.ns3.p2v', description=(
        'A pedestrian-to-vehicle study at one crossing in ns-3: pedestrians\' phones '
        'broadcast safety messages over 802.11p, vehicles warn from them; the same run '
        'with no GPS errors, white noise and the package\'s profiles. Needs the extra '
        '"ns3".'))
    p.add_argument('--pedestrians', type=int, default=100, help='phones at the crossing')
    p.add_argument('--vehicles', type=int, default=20, help='vehicles driving through it')
    p.add_argument('--duration', type=float, default=60.0, help='simulated seconds')
    p.add_argument('--rate', type=float, default=10.0,
                   help='messages per second per pedestrian (1-10)')
    p.add_argument('--size', type=int, default=200, help='bytes per message on the air')
    p.add_argument('--conditions', default=','.join(DEFAULT_CONDITIONS),
                   help='none, a profile, or white:PROFILE, comma-separated')
    p.add_argument('--seed', type=int, default=1, help='the GPS errors\' seed')
    p.add_argument('--scenario-seed', type=int, default=7,
                   help='the tracks\' and the network\'s seed')
    p.add_argument('--jobs', type=int, default=os.cpu_count() or 1,
                   help='conditions run at a time (a process each)')
    p.add_argument('--out', default='p2v_output', help='directory for p2v.json and p2v.png')
    a = p.parse_args(argv)
    if not 1.0 <= a.rate <= 10.0 or a.pedestrians < 1 or a.vehicles < 1 or a.duration <= 0:
        p.error('expected --rate 1-10, at least one pedestrian and one vehicle, and a '
                'positive --duration')
    peds, cars = scenario(a.pedestrians, a.vehicles, a.duration, a.scenario_seed)
    spec = WorldSpec(peds, cars, a.duration, a.rate, a.size, a.seed, a.scenario_seed)
    start = time.perf_counter()
    conditions = tuple(a.conditions.split(','))
    out = Path(a.out)
    try:
        for name in conditions:
            condition_profile(name)     # a bad name fails before anything is written
        out.mkdir(parents=True, exist_ok=True)
        result = study(spec, conditions, a.jobs)
    except (ValueError, OSError) as exc:
        print(f'p2v: {exc}', file=sys.stderr)
        return 2
    result['run'] = {**vars(a), 'wall_s': time.perf_counter() - start}
    (out / 'p2v.json').write_text(json.dumps(result, indent=1))
    from gps_error_ros.reports.p2v_figure import p2v_figure
    p2v_figure(result, out / 'p2v.png')
    print(table(result))
    print(f'wrote {out / "p2v.json"} and {out / "p2v.png"}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
