"""
Long blind run of ``gps_error diagnose`` on synthetic walks (make diagnose-long).

For every effect-free scenario (``none``, ``ar5``, ``quantised``) ``--seeds``
walks (default 100): a false alarm is any effect attributed or anything
reported unexplained. Holm keeps the family-wise level at 5 %, so the count
must not exceed the binomial(seeds, 0.05) bound at 1 % (the run fails
otherwise). For every scenario with an effect, ``--effect-seeds`` walks
(default 20; pairs of effects among them): the share with exactly the
right attribution, the share where the cross-validated selection kept
exactly the right effects, and the share where the held-out NLL after is
lower than before, printed; the run fails if the right attribution is
below ``--min-power`` (default 90 %) or, where an effect is expected, the
held-out NLL is lower after in less than ``--min-better`` (default 95 %).

Prints one line per scenario and a JSON summary (``--json``); exits non-zero
on a failed check. Seeds start at 1000 (``--first-seed``), apart from the
test suite's. Each share is printed with its Clopper-Pearson 95 % interval,
and the shares pooled over the effect scenarios beside them.
"""

import argparse
from concurrent.futures import ProcessPoolExecutor
import json
import os
import sys
import time

from scipy import stats

from gps_error_ros.diagnose import ALPHA, diagnose
from gps_error_ros.fit.fidelity import binomial_interval
from gps_error_ros.sim.synthetic import EFFECT_FREE, SCENARIOS, synthetic_trace


def one(job):
    scenario, seed, duration = job
    s = diagnose(synthetic_trace(scenario, seed, duration), sims=10).findings
    return {'scenario': scenario, 'seed': seed,
            'effects': s.effect_names,
            'kept': list(s.selection.kept),
            'unexplained': [u.structure for u in s.unexplained],
            'before': s.error_before.heldout_nll_per_sample,
            'after': s.error_after.heldout_nll_per_sample}


def _share(k, n):
    """Return 'k of n (p %, 95 % CI lo-hi %)' with the Clopper-Pearson interval."""
    lo, hi = binomial_interval(k, n)
    return f'{k} of {n} ({100 * k / n:.0f} %, 95 % CI {100 * lo:.0f}-{100 * hi:.0f} %)'


def _effect_free_row(sc, rows):
    n = len(rows)
    alarms = sum(bool(r['effects'] or r['unexplained']) for r in rows)
    bound = int(stats.binom.ppf(0.99, n, ALPHA))
    line = (f'{sc:32s} {n} seeds: false alarms {alarms} ({100 * alarms / n:.1f} %), '
            f'bound {bound} (binomial({n}, {ALPHA}) 99 % quantile)')
    return line, {'seeds': n, 'false_alarms': alarms, 'bound': bound,
                  'passed': alarms <= bound}


def _effect_row(sc, rows, args):
    expected, unexplained = SCENARIOS[sc]
    n = len(rows)
    right = sum(sorted(r['effects']) == sorted(expected)
                and bool(r['unexplained']) == unexplained for r in rows)
    better = sum(r['after'] < r['before'] for r in rows)
    kept = sum(sorted(r['kept']) == sorted(expected) for r in rows)
    passed = right / n >= args.min_power and \
        (not expected or better / n >= args.min_better)
    line = (f'{sc:32s} {n} seeds: right attribution {_share(right, n)}, '
            f'kept for simulation {kept}, held-out NLL lower after {_share(better, n)}')
    return line, {'seeds': n, 'right': right, 'kept_right': kept, 'after_better': better,
                  'passed': passed, 'found': sorted({tuple(r['effects']) for r in rows})}


def _pooled(summary):
    """Return the lines and the record of the shares pooled over the effect scenarios."""
    rows = {sc: v for sc, v in summary.items() if 'right' in v}
    if not rows:
        return [], {}
    n = sum(v['seeds'] for v in rows.values())
    right = sum(v['right'] for v in rows.values())
    fitted = [v for sc, v in rows.items() if SCENARIOS[sc][0]]
    nb, better = sum(v['seeds'] for v in fitted), sum(v['after_better'] for v in fitted)
    lines = [f'{"pooled over the effect scenarios":32s} right attribution {_share(right, n)}']
    if nb:
        lines.append(f'{"":32s} held-out NLL lower after {_share(better, nb)} '
                     f'(scenarios with an effect to fit)')
    return lines, {'seeds': n, 'right': right, 'after_better': better,
                   'after_better_seeds': nb}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--seeds', type=int, default=100)
    p.add_argument('--effect-seeds', type=int, default=20)
    p.add_argument('--first-seed', type=int, default=1000,
                   help='seed of the first walk of every scenario (default 1000)')
    p.add_argument('--duration', type=int, default=3600)
    p.add_argument('--min-power', type=float, default=0.9)
    p.add_argument('--min-better', type=float, default=0.95)
    p.add_argument('--workers', type=int, default=os.cpu_count() or 1)
    p.add_argument('--json', default=None)
    p.add_argument('--scenarios', nargs='+', choices=list(SCENARIOS), default=list(SCENARIOS),
                   help='run only these scenarios (default: all)')
    args = p.parse_args(argv)
    jobs = [(sc, args.first_seed + i, args.duration) for sc in args.scenarios
            for i in range(args.seeds if sc in EFFECT_FREE else args.effect_seeds)]
    t0 = time.monotonic()
    with ProcessPoolExecutor(args.workers) as ex:
        results = list(ex.map(one, jobs, chunksize=2))
    ok, summary = True, {}
    for sc in args.scenarios:
        rows = [r for r in results if r['scenario'] == sc]
        line, summary[sc] = (_effect_free_row(sc, rows) if sc in EFFECT_FREE
                             else _effect_row(sc, rows, args))
        ok &= summary[sc]['passed']
        print(line + ('' if summary[sc]['passed'] else '  FAILED'))
    lines, pooled = _pooled(summary)
    print('\n'.join(lines))
    wall = time.monotonic() - t0
    print(f'{len(jobs)} diagnoses in {wall:.0f} s: {"PASSED" if ok else "FAILED"}')
    if args.json:
        with open(args.json, 'w') as f:
            json.dump({'summary': summary, 'pooled': pooled, 'wall_s': wall,
                       'runs': results,
                       'command': ' '.join(['python bench/diagnose_long.py']
                                           + list(sys.argv[1:] if argv is None else argv))},
                      f, indent=1)
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main())
