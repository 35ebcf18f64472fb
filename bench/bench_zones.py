"""
Zone maps: what following the zone costs per step, 5,000 agents, 100 zones.

The error node's core (:class:`FixEngine`) steps 5,000 walkers on a 10 x 10
grid of square zones (about 2 km across, profiles DS1, DS2, DS5, DS7 in
turn), one truth sample per agent per step, once without zones and once with
them, in the same run. Printed: milliseconds per step (truth in, clock, fixes
out) of each, their ratio, and the point-in-polygon lookup's own share (one
vectorised ``STRtree`` query per step). Then the same with a ``population``
section in the default profile (each agent's bias, wandering, and scale,
kept across zones), without and with zones. Best of a few repeats.
"""

import argparse
from dataclasses import replace
import json
import time

import numpy as np

from gps_error_ros.model.population import Population
from gps_error_ros.model.profiles import load_profile
from gps_error_ros.model.streams import agent_keys
from gps_error_ros.model.zoned import zoned_errors
from gps_error_ros.model.zones import zone_map_from_dict
from gps_error_ros.sim.engine import FixEngine, NS

LAT0, LON0 = 40.75, -73.99
CELL = 0.002              # degrees: ~220 m north-south, ~170 m east-west
GRID = 10
PROFILES = ('DS1', 'DS2', 'DS5', 'DS7')


def grid_map():
    """Return a 10 x 10 grid of square zones as a ZoneMap."""
    features = []
    for i in range(GRID):
        for j in range(GRID):
            lon0, lat0 = LON0 + j * CELL, LAT0 + i * CELL
            ring = [[lon0, lat0], [lon0 + CELL, lat0], [lon0 + CELL, lat0 + CELL],
                    [lon0, lat0 + CELL], [lon0, lat0]]
            features.append({'type': 'Feature', 'geometry': {'type': 'Polygon',
                                                             'coordinates': [ring]},
                             'properties': {'name': f'z{i}_{j}',
                                            'profile': PROFILES[(i + j) % 4]}})
    return zone_map_from_dict({'type': 'FeatureCollection', 'features': features})


def walk(n, steps, seed=0):
    """Return lat, lon (steps, n): walkers at 1.4 m/s across the grid."""
    rng = np.random.default_rng(seed)
    lat = LAT0 + rng.uniform(0, GRID * CELL, n)
    lon = LON0 + rng.uniform(0, GRID * CELL, n)
    heading = rng.uniform(0, 2 * np.pi, n)
    dlat = 1.4 * np.cos(heading) / 111320.0
    dlon = 1.4 * np.sin(heading) / (111320.0 * np.cos(np.radians(LAT0)))
    k = np.arange(steps)[:, None]
    return lat + k * dlat, lon + k * dlon


def run_engine(zones, n, steps, lat, lon, profile):
    """Return seconds per step of a FixEngine run (truth in, clock, fixes out)."""
    z = None
    if zones is not None:
        profile, model, z = zoned_errors(zones, profile)
    else:
        model = profile.model()
    engine = FixEngine(model, agent_keys(1, [f'p{i}' for i in range(n)]), zones=z)
    agents = np.arange(n)
    coords = np.zeros((n, 3))
    t0 = time.perf_counter()
    for k in range(1, steps + 1):
        coords[:, 0], coords[:, 1] = lat[k - 1], lon[k - 1]
        engine.add_truth_batch(agents, np.full(n, k * NS), coords)
        fixes = engine.on_clock(k * NS)
        assert sum(f.agents.size for f in fixes) == n or k == 1
    return (time.perf_counter() - t0) / steps


def run(n=5000, steps=120, repeats=3):
    zmap = grid_map()
    lat, lon = walk(n, steps + 1)
    ds2 = load_profile('DS2')
    plain = min(run_engine(None, n, steps, lat, lon, ds2) for _ in range(repeats))
    zoned = min(run_engine(zmap, n, steps, lat, lon, ds2) for _ in range(repeats))
    t0 = time.perf_counter()
    for k in range(steps):
        zmap.lookup(lat[k], lon[k])
    lookup = (time.perf_counter() - t0) / steps
    row = {'agents': n, 'zones': len(zmap), 'steps': steps,
           'ms_per_step_without_zones': 1e3 * plain, 'ms_per_step_with_zones': 1e3 * zoned,
           'ratio': zoned / plain, 'ms_per_step_lookup': 1e3 * lookup}
    print(f'{n} agents, {len(zmap)} zones: engine '
          f'{row["ms_per_step_without_zones"]:.2f} ms/step '
          f'without zones, {row["ms_per_step_with_zones"]:.2f} ms/step with '
          f'(x{row["ratio"]:.2f}); '
          f'point-in-polygon {row["ms_per_step_lookup"]:.2f} ms/step', flush=True)
    crowd = replace(ds2, population=Population((2.0, 3.0), 0.3, 600.0))
    alone = min(run_engine(None, n, steps, lat, lon, crowd) for _ in range(repeats))
    mixed = min(run_engine(zmap, n, steps, lat, lon, crowd) for _ in range(repeats))
    row['population'] = {'ms_per_step_without_zones': 1e3 * alone,
                         'ms_per_step_with_zones': 1e3 * mixed, 'ratio': mixed / alone,
                         'ratio_to_plain': mixed / plain}
    print(f'  with a population section: {1e3 * alone:.2f} ms/step without zones, '
          f'{1e3 * mixed:.2f} with (x{mixed / alone:.2f}; x{mixed / plain:.2f} the engine '
          f'without either)', flush=True)
    return row


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--json', help='write the figures here')
    p.add_argument('--smoke', action='store_true', help='200 agents, 5 steps (seconds)')
    args = p.parse_args()
    row = run(n=200, steps=5, repeats=1) if args.smoke else run()
    if args.json:
        with open(args.json, 'w') as f:
            json.dump(row, f, indent=1)


if __name__ == '__main__':
    main()
