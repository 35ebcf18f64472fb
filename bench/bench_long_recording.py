"""
Long recordings: ``gps_error diagnose`` and ``compare`` on a day at 1 Hz.

Writes a synthetic walk with reflections (``gps_error synth reflections``:
the jump filter and its parameter search are the costly part) of one hour
and of ``--hours`` (default 24), runs each command on each in a process of
its own, and prints wall time and peak resident memory, the long case
beside the one-hour baseline measured in the same run. Goals: the long case
in under ``--max-s`` seconds (120) and ``--max-mb`` MB (1,000); the exit
status says whether they held.
"""

import argparse
import json
from pathlib import Path
import subprocess
import sys
import tempfile
import time

#: Runs a gps_error command in this interpreter and prints its peak RSS (kB) last.
CHILD = ('import resource, sys\n'
         'from gps_error_ros.cli import main\n'
         'rc = main(sys.argv[1:])\n'
         'print("PEAK_KB", resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)\n'
         'sys.exit(rc)\n')


def run(args):
    """Return (seconds, peak MB) of one gps_error command in a fresh process."""
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, '-c', CHILD, *args], capture_output=True,
                          text=True)
    seconds = time.perf_counter() - t0
    if done.returncode != 0:
        raise SystemExit(f'gps_error {" ".join(args)} failed:\n{done.stderr[-2000:]}')
    peak = [ln for ln in done.stdout.splitlines() if ln.startswith('PEAK_KB')]
    return seconds, int(peak[-1].split()[1]) / 1024.0


def main(argv=None):
    """Run the benchmark; return 0 when the long case met its goals."""
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--hours', type=float, default=24.0)
    p.add_argument('--base-hours', type=float, default=1.0)
    p.add_argument('--max-s', type=float, default=120.0)
    p.add_argument('--max-mb', type=float, default=1000.0)
    p.add_argument('--scenario', default='reflections',
                   help='the synthetic walk (gps_error synth); reflections by default')
    p.add_argument('--json', help='write the figures here')
    args = p.parse_args(argv)
    out, ok = {}, True
    with tempfile.TemporaryDirectory() as work:
        for hours in (args.base_hours, args.hours):
            walk = str(Path(work, f'walk_{hours:g}h.csv'))
            run(['synth', args.scenario, '-o', walk, '--seed', '1',
                 '--duration', str(int(hours * 3600))])
            for command in ('diagnose', 'compare'):
                seconds, mb = run([command, walk])
                out[f'{command}_{hours:g}h'] = {'seconds': round(seconds, 1),
                                                'peak_rss_mb': round(mb)}
                line = f'{command} on {hours:g} h at 1 Hz: {seconds:.1f} s, peak RSS {mb:.0f} MB'
                if hours == args.hours:
                    base = out[f'{command}_{args.base_hours:g}h']
                    met = seconds <= args.max_s and mb <= args.max_mb
                    ok &= met
                    line += (f' (x{seconds / base["seconds"]:.1f} time, '
                             f'x{mb / base["peak_rss_mb"]:.1f} memory of {args.base_hours:g} h; '
                             f'goal {args.max_s:g} s, {args.max_mb:g} MB: '
                             f'{"met" if met else "NOT MET"})')
                print(line, flush=True)
    out['goals_met'] = ok
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1) + '\n')
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main())
