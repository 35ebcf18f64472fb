"""
``gps_error simulate`` on a SUMO FCD file of 1,000 persons for one hour.

Generates the file (persons walking a grid near the Manhattan datum, written
as with ``--fcd-output.geo``, 1 s period; each person departs in the first
minute), then times ``gps_error simulate`` on it in a separate process and
reads that process's peak resident memory. Baseline measured in the same
run: one read-only ``iterparse`` pass over the same file.
"""

import argparse
import json
import os
from pathlib import Path
import resource
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET

import numpy as np


def write_fcd(path, persons=1000, seconds=3600, seed=0):
    rng = np.random.default_rng(seed)
    lat0, lon0 = 40.7506, -73.9904
    start = rng.integers(0, 60, persons)
    heading = rng.uniform(0, 2 * np.pi, persons)
    speed = rng.uniform(1.1, 1.6, persons)
    m_lat, m_lon = 1 / 111_320.0, 1 / (111_320.0 * np.cos(np.radians(lat0)))
    with open(path, 'w') as f:
        f.write('<?xml version="1.0" encoding="UTF-8"?>\n<fcd-export>\n')
        for t in range(seconds):
            f.write(f'    <timestep time="{t:.2f}">\n')
            on = np.flatnonzero(start <= t)
            d = (t - start[on]) * speed[on]
            # walk out and back along a 400 m leg
            leg = np.abs((d % 800.0) - 400.0)
            lat = lat0 + leg * np.cos(heading[on]) * m_lat
            lon = lon0 + leg * np.sin(heading[on]) * m_lon
            f.write(''.join(
                f'        <person id="p{i}" x="{x:.8f}" y="{y:.8f}" angle="0.00" '
                f'speed="{s:.2f}" pos="0.00" edge="e{i % 50}" slope="0.00"/>\n'
                for i, x, y, s in zip(on, lon, lat, speed[on])))
            f.write('    </timestep>\n')
        f.write('</fcd-export>\n')


def parse_only(path):
    n = 0
    for _, elem in ET.iterparse(path, events=('end',)):
        if elem.tag == 'timestep':
            n += len(elem)
            elem.clear()
    return n


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--json', help='write the figures here')
    p.add_argument('--persons', type=int, default=1000)
    p.add_argument('--seconds', type=int, default=3600)
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as work:
        src, dst = Path(work, 'fcd.xml'), Path(work, 'noisy.xml')
        t0 = time.perf_counter()
        write_fcd(src, args.persons, args.seconds)
        t_gen = time.perf_counter() - t0
        t0 = time.perf_counter()
        positions = parse_only(src)
        t_parse = time.perf_counter() - t0
        exe = Path(sys.executable).with_name('gps_error')
        t0 = time.perf_counter()
        # the file is written here, not by SUMO: it has no options comment
        # saying lon/lat, so the command is told
        subprocess.run([str(exe), 'simulate', '--profile', 'DS5', '--seed', '1',
                        '--trajectories', str(src), '--out', str(dst),
                        '--coordinates', 'lonlat'], check=True)
        t_sim = time.perf_counter() - t0
        peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
        row = {'persons': args.persons, 'seconds': args.seconds,
               'positions': positions, 'input_mb': os.path.getsize(src) / 2 ** 20,
               'output_mb': os.path.getsize(dst) / 2 ** 20,
               'simulate_s': t_sim, 'peak_rss_mb': peak_mb,
               'parse_only_s': t_parse, 'ratio_to_parse_only': t_sim / t_parse,
               'positions_per_s': positions / t_sim, 'generate_s': t_gen}
    print(f'gps_error simulate on SUMO FCD, {args.persons} persons x {args.seconds} s '
          f'({positions} positions, {row["input_mb"]:.0f} MB): {t_sim:.1f} s '
          f'({row["positions_per_s"] / 1e3:.0f} k positions/s), peak RSS '
          f'{peak_mb:.0f} MB; a read-only iterparse pass takes {t_parse:.1f} s '
          f'(x{row["ratio_to_parse_only"]:.1f})', flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(row, indent=1))


if __name__ == '__main__':
    main()
