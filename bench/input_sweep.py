"""
Every fitting command on altered copies of the measured recordings.

Stands in for recordings not yet seen: each trace CSV of ``--data`` is
altered in ways a real recording can differ (its first 40 % or last 45 %
alone, a fix every 3 s, a cluster of failed fixes kilometres off and no
accuracy column, empty fix cells and a 200-s gap, errors 2.5 times as
large, a Unix time base, broken accuracy values, a fifth of the fixes
failed, five minutes standing still first), and ``calibrate`` (with and
without ``--population``), ``validate``, ``diagnose`` and ``compare`` run
on each. A run passes when it exits 0 with nothing on standard error, or
exits 2 with one line that names the recording (a refusal). Anything
else, a warning or a traceback among them, fails the sweep. The copies are
written to a temporary folder and removed.

``make input-sweep`` runs it on ``data/`` (about 25 minutes on two
cores); ``--only`` restricts it to recordings whose name holds a text.
"""

import argparse
from concurrent.futures import ThreadPoolExecutor
import csv
from pathlib import Path
import random
import subprocess
import sys
import tempfile
import time


def _rows(path):
    with open(path, newline='', encoding='utf-8-sig') as f:
        rows = list(csv.reader(f))
    return rows[0], [r for r in rows[1:] if r]


def _write(path, header, rows):
    with open(path, 'w', newline='') as f:
        w = csv.writer(f, lineterminator='\n')
        w.writerow(header)
        w.writerows(rows)


def variants(path, rng):
    """Yield (suffix, header, rows): the altered copies of one trace CSV."""
    header, rows = _rows(path)
    n = len(rows)
    col = {c: i for i, c in enumerate(header)}
    lat, lon, t = col['lat'], col['lon'], col['t']
    yield 'head40', header, rows[:int(n * 0.4)]
    yield 'tail45', header, rows[int(n * 0.55):]
    yield 'every3', header, rows[::3]
    keep = [c for c in header if c != 'accuracy']
    failed = [[r[col[c]] for c in keep] for r in rows]
    k, klat, klon = min(25, n // 20), keep.index('lat'), keep.index('lon')
    for r in failed[int(n * 0.3):int(n * 0.3) + k + 1]:
        r[klat] = f'{float(r[klat]) + 0.02 + rng.gauss(0, 0.005):.8f}'
    failed[3][klon] = f'{float(failed[3][klon]) - 0.3:.8f}'
    yield 'failcluster', keep, failed
    mid = float(rows[n // 2][t])
    gaps = [list(r) for r in rows if not mid < float(r[t]) < mid + 200]
    for r in gaps[10:14]:
        r[lat] = r[lon] = ''
    yield 'gaps', header, gaps
    scaled = []
    for r in rows:
        r = list(r)
        for c, truth in ((lat, col['truth_lat']), (lon, col['truth_lon'])):
            r[c] = f'{float(r[c]) + 1.5 * (float(r[c]) - float(r[truth])):.9f}'
        scaled.append(r)
    yield 'scaled', header, scaled
    unix = [list(r) for r in rows]
    for r in unix:
        r[t] = f'{float(r[t]) + 1.7e9:.3f}'
    yield 'unix', header, unix
    bad = [list(r) for r in rows]
    acc = header + ([] if 'accuracy' in header else ['accuracy'])
    for i, r in enumerate(bad):
        r += [] if 'accuracy' in header else ['5.0']
        r[acc.index('accuracy')] = ('0' if i % 7 == 0 else '-1' if i % 11 == 3 else
                                    '' if i % 13 == 5 else r[acc.index('accuracy')])
    yield 'accbad', acc, bad
    many = [list(r) for r in rows]
    for r in many:
        if rng.random() < 0.2:
            r[lat] = f'{float(r[lat]) + rng.choice((-1, 1)) * rng.uniform(0.005, 0.2):.8f}'
    yield 'manyfail', header, many
    first, t0 = rows[0], float(rows[0][t])
    still = []
    for i in range(300):
        r = list(first)
        r[t] = f'{t0 - 300 + i:.3f}'
        r[lat] = f'{float(first[col["truth_lat"]]) + rng.gauss(0, 2e-5):.8f}'
        r[lon] = f'{float(first[col["truth_lon"]]) + rng.gauss(0, 2e-5):.8f}'
        if 'speed' in col:
            r[col['speed']] = '0'
        still.append(r)
    yield 'still', header, still + rows


def commands(csv_path, out):
    """Return (name, argv) of the commands run on one altered copy."""
    g = [str(Path(sys.executable).with_name('gps_error'))]
    return [('calibrate', g + ['calibrate', str(csv_path), '-o', str(out / 'p.yaml')]),
            ('calibrate --population', g + ['calibrate', str(csv_path), '-o',
                                            str(out / 'pp.yaml'), '--population']),
            ('validate', g + ['validate', 'DS5', str(csv_path), '--out', str(out / 'v'),
                              '--sims', '50']),
            ('diagnose', g + ['diagnose', str(csv_path), '--sims', '20']),
            ('compare', g + ['compare', str(csv_path), '--sims', '20'])]


def judge(rc, err):
    """Return '' for a pass, else why the run fails."""
    lines = err.strip().splitlines()
    if rc == 0 and not lines:
        return ''
    if rc == 2 and len(lines) == 1 and lines[0].startswith('gps_error '):
        return ''
    return f'exit {rc}, {len(lines)} line(s) on standard error'


def run_one(csv_path, work):
    """Run every command on one copy; return rows (copy, command, rc, s, verdict, line)."""
    out = work / csv_path.stem
    out.mkdir()
    rows = []
    for name, argv in commands(csv_path, out):
        start = time.monotonic()
        run = subprocess.run(argv, capture_output=True, text=True)
        last = (run.stderr.strip().splitlines() or [''])[-1]
        rows.append((csv_path.stem, name, run.returncode, time.monotonic() - start,
                     judge(run.returncode, run.stderr), last))
    return rows


#: The repository's measured recordings (data/README.md).
DATA = Path(__file__).resolve().parents[1] / 'data'


def main(argv=None):
    """Write the copies, run the commands, print a line per run; exit 1 on a failure."""
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--data', default=str(DATA), help='folder of trace CSVs')
    ap.add_argument('--only', default='', help='only recordings whose name holds this')
    ap.add_argument('--jobs', type=int, default=2, help='copies run at once')
    args = ap.parse_args(argv)
    rng = random.Random(5)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        copies = []
        for src in sorted(Path(args.data).glob('*.csv')):
            if args.only not in src.name:
                continue
            for suffix, header, rows in variants(src, rng):
                copies.append(work / f'{src.stem}__{suffix}.csv')
                _write(copies[-1], header, rows)
        if not copies:
            ap.error(f'--data {args.data} --only {args.only!r}: no trace CSV (*.csv) '
                     f'to alter')
        print(f'{len(copies)} altered copies of the recordings in {args.data}, '
              f'{len(commands(copies[0], work))} commands each')
        failed = 0
        with ThreadPoolExecutor(args.jobs) as pool:
            for rows in pool.map(lambda c: run_one(c, work), copies):
                for copy, name, rc, s, verdict, last in rows:
                    failed += bool(verdict)
                    said = verdict or ('refused: ' + last[:160] if rc else 'ok')
                    print(f'{"FAIL" if verdict else "pass"}  {copy}  {name}  {s:.0f} s  '
                          f'{said}', flush=True)
        print(f'{failed} failed')
        return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
