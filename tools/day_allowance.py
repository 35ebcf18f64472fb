"""
The evidence for calibrate's allowance for other days (decision 0029).

A population fitted from one occasion knows how its 300-s blocks differ,
not how days differ. Recordings of several occasions of one receiver say
how much more the bias moves between days: the two-scale population fit of
all of them gives a part held for the run (between occasions) and a wander
(between blocks within one); their horizontal RMS ratio is the allowance's
``ratio``. This prints that ratio, and judges it: for every recording long
enough for a population of its own (3 blocks) and every recording of
another occasion, the population fitted on the first alone (the Gaussian AR
within, as ``calibrate --population --within ar`` writes it) is scored on the second
with no allowance, with the ratio of the other occasions (the held-out
occasion left out of it) and with the ratio of all: the held-out NLL per
sample and whether the held-out mean error lies inside the 95 % range of
the means of ``--sims`` traces simulated along it (the ``bias`` group of
the generalisation page).

    python tools/day_allowance.py [--data data] [--sims 200]
"""

import argparse
from dataclasses import replace
import math
from pathlib import Path
import sys

import numpy as np

from gps_error_ros.fit.fidelity import simulate_part
from gps_error_ros.judge.population_class import PopulationClass
from gps_error_ros.fit.holdout import cut_trace
from gps_error_ros.fit.calibration import calibrate, without_gross_failures
from gps_error_ros.fit.population_fit import BLOCK_S, DAY_RATIO, MIN_BLOCKS, occasions
from gps_error_ros.model.population import WithPopulation
from gps_error_ros.traces.trace_io import join_recordings, read_trace_csv

#: The repository's measured recordings (data/README.md).
DATA = Path(__file__).resolve().parents[1] / 'data'
#: The recordings of several occasions of one receiver: the SnapperGPS walks.
WALKS = 'snapper-walk-*.csv'


def day_ratio(recordings):
    """Return the held part's horizontal RMS over the wander's, or None (no two-scale fit)."""
    ev = calibrate(recordings, population=True, day_allowance=0.0).population.evidence
    if 'held_sd_estimate_m' not in ev:
        return None
    return float(np.hypot(*ev['held_sd_estimate_m']) / np.hypot(*ev['wander_sd_estimate_m']))


def _part(trace, held_out):
    """Return (the trace's part on the grid, its truth), gross failures set aside."""
    kept, _ = without_gross_failures([trace])
    clean = join_recordings(kept)
    train, test, truth, _ = cut_trace(clean, cut_t=clean.t[0] - 1.0 if held_out
                                      else clean.t[-1] + 1.0)
    return (test if held_out else train), truth


def judge(cls, pop0, ratio, test, truth, sims):
    """Return (held-out NLL per sample, the held-out mean inside its range per axis)."""
    held = ratio * math.sqrt(0.5 * (pop0.bias_sd_m[0] ** 2 + pop0.bias_sd_m[1] ** 2))
    pop = pop0 if ratio == 0 else replace(pop0, run_bias_sd_m=(held, held))
    cls.fit = replace(cls.fit, population=pop)
    cls.model = WithPopulation(cls.ar, pop)
    nll = -float(np.mean(cls.logpdf(test, 3)))
    means = np.array([np.concatenate(s).mean(axis=0)
                      for s in simulate_part(cls, test, truth, sims, 0)])
    lo, hi = np.percentile(means, [2.5, 97.5], axis=0)
    measured = np.concatenate(test.err).mean(axis=0)
    return nll, [bool(lo[a] <= measured[a] <= hi[a]) for a in range(2)]


def main(argv=None):
    """Print the ratio and the folds; exit 0."""
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--data', type=Path, default=DATA)
    ap.add_argument('--sims', type=int, default=200)
    args = ap.parse_args(argv)
    paths = sorted(args.data.glob(WALKS))
    traces = [read_trace_csv(p) for p in paths]
    occ = occasions(traces)
    print(f'{len(traces)} recordings, {len(set(occ))} occasions; the ratio of all: '
          f'{day_ratio(traces):.3f} (calibrate uses {DAY_RATIO:g})')
    rows = []
    for i, tr in enumerate(traces):
        train, _ = _part(tr, held_out=False)
        if train.n < MIN_BLOCKS * BLOCK_S:
            continue
        cls = PopulationClass(train)
        if cls.fit.population is None:
            continue
        pop0 = cls.fit.population
        for j, other in enumerate(traces):
            if occ[j] == occ[i]:
                continue
            loo = day_ratio([t for t, o in zip(traces, occ) if o != occ[j]])
            test, truth = _part(other, held_out=True)
            got = {label: judge(cls, pop0, r, test, truth, args.sims)
                   for label, r in (('none', 0.0), ('others', loo), ('all', DAY_RATIO))
                   if r is not None}
            rows.append(got)
            print(f'train {tr.name}, hold out {other.name} (ratio of the other occasions '
                  f'{loo:.3f}): ' + '; '.join(
                      f'{k} NLL {v[0]:.4f}, mean inside {v[1][0]}/{v[1][1]}'
                      for k, v in got.items()))
    _summary(rows, ('none', 'others', 'all'))
    # the same day: what the allowance costs a profile used on the day it was fitted on
    same = []
    for path in sorted(args.data.glob('*.csv')):
        tr = read_trace_csv(path)
        kept, _ = without_gross_failures([tr])
        train, test, truth, _ = cut_trace(join_recordings(kept))
        cls = PopulationClass(train) if train.n >= MIN_BLOCKS * BLOCK_S else None
        if cls is None or cls.fit.population is None:
            continue
        pop0 = cls.fit.population
        got = {label: judge(cls, pop0, r, test, truth, args.sims)
               for label, r in (('none', 0.0), ('all', DAY_RATIO))}
        same.append(got)
        print(f'same day, {tr.name}: first 70 % trains, the rest held out: ' + '; '.join(
            f'{k} NLL {v[0]:.4f}, mean inside {v[1][0]}/{v[1][1]}' for k, v in got.items()))
    _summary(same, ('none', 'all'))
    return 0


def _summary(rows, labels):
    """Print, per allowance, how often the held-out mean was inside and the NLL's change."""
    for label in labels:
        have = [r for r in rows if label in r]
        both = sum(all(r[label][1]) for r in have)
        axes = sum(sum(r[label][1]) for r in have)
        gain = [r[label][0] - r['none'][0] for r in have]
        print(f'{label}: {len(have)} folds, the held-out mean inside on both axes in {both}, '
              f'{axes} of {2 * len(have)} axes; NLL less no allowance: mean '
              f'{np.mean(gain):+.4f}, from {min(gain):+.4f} to {max(gain):+.4f}')


if __name__ == '__main__':
    sys.exit(main())
