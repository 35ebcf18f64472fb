"""
``gps_error simulate`` on SUMO's FCD as Parquet: one hour of 10,000 persons.

Writes the file as SUMO 1.28 does with ``--fcd-output fcd.parquet
--fcd-output.geo true`` (its eleven person columns, one row per person and
second; persons walking a grid near the Manhattan datum, each departing in
the first minute), then measures, each command in a process of its own
(time and peak resident memory):

* the floor: pyarrow reading the file a batch at a time (as ``simulate``
  reads it) and writing every column back with ``simulate``'s writer
  options, with no model (and, for reference, with pyarrow's default
  options);
* ``gps_error simulate`` on it (DS5, stated accuracy);
* today's XML path on the same persons' first ten minutes, as XML;
* the file split by agent (``gps_error split``) and its parts run on a local
  Dask cluster of 1 and of 2 worker processes.

Goals: within 3x the floor; at least 1 M positions/s; peak memory under
1 GB. The moonshot: 1e9 positions (a city's day) in under 10 minutes.
"""

import argparse
import json
from pathlib import Path
import subprocess
import sys
import tempfile
import time

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

LAT0, LON0 = 40.7506, -73.9904


def positions(persons, t, rng_state):
    """Return (on, lon, lat, speed) of the persons present at second t."""
    start, heading, speed = rng_state
    on = np.flatnonzero(start <= t)
    d = (t - start[on]) * speed[on]
    leg = np.abs((d % 800.0) - 400.0)            # out and back along a 400 m leg
    lat = LAT0 + leg * np.cos(heading[on]) / 111_320.0
    lon = LON0 + leg * np.sin(heading[on]) / (111_320.0 * np.cos(np.radians(LAT0)))
    return on, lon, lat, speed[on]


def write_parquet(path, persons, seconds, seed=0, group_rows=1 << 20):
    """Write SUMO's FCD Parquet columns for ``persons`` over ``seconds``; return rows."""
    rng = np.random.default_rng(seed)
    state = (rng.integers(0, 60, persons), rng.uniform(0, 2 * np.pi, persons),
             rng.uniform(1.1, 1.6, persons))
    ids = pa.array([f'p{i}' for i in range(persons)])
    edges = pa.array([f'e{i}' for i in range(50)])
    writer, parts, held, rows = None, [], 0, 0
    for t in range(seconds):
        parts.append((t, *positions(persons, t, state)))
        held += parts[-1][1].size
        if held < group_rows and t < seconds - 1:
            continue
        on = np.concatenate([p[1] for p in parts])
        n = on.size
        f32 = np.zeros(n, dtype=np.float32)
        table = pa.table({
            'timestep_time': np.concatenate([np.full(p[1].size, float(p[0])) for p in parts]),
            'person_id': pc.take(ids, pa.array(on)),
            'person_x': np.concatenate([p[2] for p in parts]),
            'person_y': np.concatenate([p[3] for p in parts]),
            'person_angle': f32, 'person_type': pa.repeat('DEFAULT_PEDTYPE', n),
            'person_speed': np.concatenate([p[4] for p in parts]).astype(np.float32),
            'person_pos': f32, 'person_lane': pa.nulls(n, pa.string()),
            'person_edge': pc.take(edges, pa.array(on % 50)), 'person_slope': f32})
        if writer is None:
            writer = pq.ParquetWriter(path, table.schema)
        writer.write_table(table)
        rows += n
        parts, held = [], 0
    writer.close()
    return rows


def write_xml(path, persons, seconds, seed=0):
    """Write the same persons' first ``seconds`` as SUMO's FCD XML (lon/lat)."""
    rng = np.random.default_rng(seed)
    state = (rng.integers(0, 60, persons), rng.uniform(0, 2 * np.pi, persons),
             rng.uniform(1.1, 1.6, persons))
    with open(path, 'w') as f:
        f.write('<?xml version="1.0" encoding="UTF-8"?>\n<fcd-export>\n')
        for t in range(seconds):
            on, lon, lat, speed = positions(persons, t, state)
            f.write(f'    <timestep time="{t:.2f}">\n' + ''.join(
                f'        <person id="p{i}" x="{x:.8f}" y="{y:.8f}" angle="0.00" '
                f'type="DEFAULT_PEDTYPE" speed="{s:.2f}" pos="0.00" edge="e{i % 50}" '
                f'slope="0.00"/>\n' for i, x, y, s in zip(on, lon, lat, speed))
                + '    </timestep>\n')
        f.write('</fcd-export>\n')


# the writer's options are simulate's (strings dictionary-encoded) or, with 'default',
# pyarrow's own (every column dictionary-encoded, which costs three times the read)
FLOOR = '''
import sys, pyarrow.parquet as pq
from gps_error_ros.traces.fcd_parquet import writer_options
f = pq.ParquetFile(sys.argv[1], pre_buffer=False, buffer_size=1 << 22); w = None
for b in f.iter_batches(batch_size=1 << 17):
    if w is None:
        options = {} if sys.argv[3] == 'default' else writer_options(b.schema)
        w = pq.ParquetWriter(sys.argv[2], b.schema, **options)
    w.write_batch(b)
w.close()
'''


def timed(cmd):
    """Run ``cmd`` in a process of its own; return (seconds, peak RSS MB)."""
    probe = ('import resource, subprocess, sys; subprocess.run(sys.argv[1:], check=True); '
             'print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)')
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, '-c', probe, *cmd], check=True,
                          capture_output=True, text=True)
    return time.perf_counter() - t0, int(done.stdout.split()[-1]) / 1024


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--json', help='write the figures here')
    p.add_argument('--persons', type=int, default=10_000)
    p.add_argument('--seconds', type=int, default=3600)
    p.add_argument('--xml-persons', type=int, default=1000)
    p.add_argument('--xml-seconds', type=int, default=600)
    p.add_argument('--smoke', action='store_true', help='tiny sizes (seconds)')
    args = p.parse_args()
    if args.smoke:
        args.persons, args.seconds, args.xml_persons, args.xml_seconds = 200, 120, 50, 60
    exe = str(Path(sys.executable).with_name('gps_error'))
    common = ['--profile', 'DS5', '--seed', '1', '--coordinates', 'lonlat']
    row = {'persons': args.persons, 'seconds': args.seconds}
    with tempfile.TemporaryDirectory() as work:
        w = Path(work)
        src = w / 'fcd.parquet'
        t0 = time.perf_counter()
        n = row['positions'] = write_parquet(src, args.persons, args.seconds)
        row['generate_s'] = time.perf_counter() - t0
        row['input_mb'] = src.stat().st_size / 2 ** 20
        row['floor_s'], row['floor_rss_mb'] = timed(
            [sys.executable, '-c', FLOOR, str(src), str(w / 'copy.parquet'), 'simulate'])
        row['floor_default_s'], _ = timed(
            [sys.executable, '-c', FLOOR, str(src), str(w / 'copy.parquet'), 'default'])
        row['simulate_s'], row['simulate_rss_mb'] = timed(
            [exe, 'simulate', '--trajectories', str(src), '--out', str(w / 'noisy.parquet'),
             *common])
        row['output_mb'] = (w / 'noisy.parquet').stat().st_size / 2 ** 20
        xml = w / 'fcd.xml'
        write_xml(xml, args.xml_persons, args.xml_seconds)
        xml_n = sum(1 for line in open(xml) if '<person ' in line)
        row['xml_positions'] = xml_n
        row['xml_s'], _ = timed([exe, 'simulate', '--trajectories', str(xml), '--out',
                                 str(w / 'noisy.xml'), *common])
        subprocess.run([exe, 'split', '--trajectories', str(src), '--parts', '8', '--out',
                        str(w / 'parts')], check=True, capture_output=True)
        for k in (1, 2):
            row[f'dask_{k}_s'], _ = timed(
                [exe, 'simulate', '--trajectories', str(w / 'parts'), '--out',
                 str(w / f'out{k}'), '--workers', str(k), *common])
    rate = n / row['simulate_s']
    row.update({'positions_per_s': rate, 'ratio_to_floor': row['simulate_s'] / row['floor_s'],
                'floor_positions_per_s': n / row['floor_s'],
                'xml_positions_per_s': row['xml_positions'] / row['xml_s'],
                'city_day_1e9_min': 1e9 / rate / 60,
                'dask_per_worker_positions_per_s': [n / row['dask_1_s'],
                                                    n / row['dask_2_s'] / 2]})
    print(f'gps_error simulate on Parquet FCD, {args.persons} persons x {args.seconds} s '
          f'({n} positions, {row["input_mb"]:.0f} MB): {row["simulate_s"]:.1f} s '
          f'({rate / 1e6:.2f} M positions/s), peak RSS {row["simulate_rss_mb"]:.0f} MB')
    print(f'  floor (pyarrow reads and writes every column, no model, simulate\'s writer '
          f'options): {row["floor_s"]:.1f} s ({row["floor_positions_per_s"] / 1e6:.2f} M/s): '
          f'x{row["ratio_to_floor"]:.2f} (goal: at most 3x); with pyarrow\'s default '
          f'options {row["floor_default_s"]:.1f} s')
    print(f'  the XML path on {row["xml_positions"]} positions: '
          f'{row["xml_positions_per_s"] / 1e3:.0f} k positions/s: Parquet is '
          f'x{rate / row["xml_positions_per_s"]:.1f} faster')
    print(f'  a city\'s day (1e9 positions) at this rate: {row["city_day_1e9_min"]:.1f} min '
          f'(moonshot: under 10)')
    print(f'  8 parts on a local Dask cluster: 1 worker {row["dask_1_s"]:.1f} s, 2 workers '
          f'{row["dask_2_s"]:.1f} s (x{row["dask_1_s"] / row["dask_2_s"]:.2f}); per worker '
          f'{n / row["dask_1_s"] / 1e6:.2f} and {n / row["dask_2_s"] / 2e6:.2f} M positions/s',
          flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(row, indent=1))


if __name__ == '__main__':
    main()
