"""
The cost of the pedestrian-to-vehicle study in ns-3 (``docs/p2v.md``, Cost).

Measures, each in a process of its own: the import of ns-3's Python
bindings (``from ns import ns``, twice), and one world of the study
(:func:`gps_error_ros.ns3.world.run_world`, messages at 10 Hz, DS5) at 100
and at 1,000 pedestrians: simulated seconds per wall second. At 100
pedestrians the same world also runs with no errors (no ``GpsSource``
work beyond reading the truth): the ratio is what the package's errors
cost inside ns-3.
"""

import argparse
import json
import subprocess
import sys
import time

SIZES = ((100, 20, 20.0), (1000, 100, 1.0))      # pedestrians, vehicles, simulated seconds


def one(pedestrians, vehicles, seconds, profile):
    """Run one world here; print its figures as JSON."""
    import numpy as np
    from gps_error_ros.ns3.p2v import condition_profile, scenario
    from gps_error_ros.ns3.world import run_world, WorldSpec
    peds, cars = scenario(pedestrians, vehicles, 60.0, 7)    # make p2v's layout, cut short
    log = run_world(WorldSpec(peds, cars, seconds), condition_profile(profile))
    print(json.dumps({'pedestrians': pedestrians, 'vehicles': vehicles, 'profile': profile,
                      'simulated_s': seconds, 'wall_s': log['wall_s'],
                      'sim_s_per_wall_s': seconds / log['wall_s'],
                      'messages_sent': int(log['tx_time'].size),
                      'received_by_vehicles': int(log['rx_time'].size),
                      'channel_busy': float(np.mean(log['busy']) / seconds)}))


def in_process(*argv):
    """Run this script's ``--one`` in a fresh process; return its JSON."""
    run = subprocess.run([sys.executable, __file__, '--one', *map(str, argv)],
                         capture_output=True, text=True, check=True)
    return json.loads(run.stdout.strip().splitlines()[-1])


def import_s():
    """Return the wall time of ``from ns import ns`` in a fresh process."""
    code = 'import time; t = time.perf_counter(); from ns import ns; ' \
           'print(time.perf_counter() - t)'
    run = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         check=True)
    return float(run.stdout.strip().splitlines()[-1])


def main():
    """Measure and print; write ``--json``."""
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--json', help='write the figures here')
    p.add_argument('--one', nargs=4, metavar=('PEDS', 'VEHICLES', 'SECONDS', 'PROFILE'),
                   help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.one:
        one(int(a.one[0]), int(a.one[1]), float(a.one[2]), a.one[3])
        return
    start = time.perf_counter()
    out = {'import_s': [import_s(), import_s()], 'worlds': []}
    print(f"from ns import ns: {out['import_s'][0]:.1f} s, {out['import_s'][1]:.1f} s")
    for peds, cars, seconds in SIZES:
        for profile in (('none', 'DS5') if peds == SIZES[0][0] else ('DS5',)):
            r = in_process(peds, cars, seconds, profile)
            out['worlds'].append(r)
            print(f"{peds:5d} pedestrians, {cars:3d} vehicles, {profile:4s}: {seconds:.0f} s "
                  f"simulated in {r['wall_s']:.1f} s: {r['sim_s_per_wall_s']:.3f} simulated "
                  f"s per wall s; {r['messages_sent']} messages, channel busy "
                  f"{r['channel_busy']:.0%}")
    w = out['worlds']
    out['errors_cost_ratio'] = w[1]['wall_s'] / w[0]['wall_s']
    print(f"DS5 against no errors at {SIZES[0][0]} pedestrians: "
          f"{out['errors_cost_ratio']:.2f}x the wall time")
    out['total_s'] = time.perf_counter() - start
    if a.json:
        with open(a.json, 'w') as f:
            json.dump(out, f, indent=1)


if __name__ == '__main__':
    main()
