"""``gps_error compare --folds`` and ``--test``: the classes across stretches and recordings."""

from dataclasses import replace
from pathlib import Path

from gps_error_ros.judge.beaten import gain_text
from gps_error_ros.judge.generalise import (EXTRA_GROUPS, GROUP_BAR, GROUPS, judge_folds,
                                            precedent_line, recording_splits,
                                            rolling_splits, split_between, summarise)
from gps_error_ros.diagnose.velocity_check import velocity_line
from gps_error_ros.judge.window_persistence import spread_line
from gps_error_ros.fit.population_fit import segment_weights
from gps_error_ros.traces.trace_io import join_recordings


def _splits(args, recordings):
    """Return [(label, Split)] of the run's rule; raise SystemExit with what was wrong."""
    if args.test:
        held, _ = recordings(args, args.test)
        parts = recordings(args)[0]
        train = join_recordings(parts)
        test = join_recordings(held)
        joined = join_recordings([train, test])
        cut = float(joined.t[-len(test.t)])
        split = split_between(joined, cut, float(joined.t[-1]) + 1.0,
                              f'train on {train.name}, hold out {test.name}')
        # recordings made together weigh as one occasion in the population fit
        weights = tuple(segment_weights(parts, split.train.t))
        return [(f'test {test.name}', replace(split, train_weights=weights))]
    traces, _ = recordings(args)
    if args.folds == 'recordings':
        if len(traces) < 2:
            raise SystemExit(f'gps_error compare: --folds recordings needs at least 2 '
                             f'recordings of one receiver, got {len(traces)}')
        return recording_splits(traces)
    return rolling_splits(join_recordings(traces))


def beaten_lines(folds):
    """Return lines on the folds where a class scores better than the population beyond noise."""
    out = []
    for f in folds:
        wb = f['classes'].get('population', {}).get('where_beaten')
        if not wb:
            continue
        gains = {part: ', '.join(f'{c} {gain_text(wb[part][c])}' for c in wb['winners']
                                 if c in wb[part]) or '-' for part in ('far', 'near')}
        out.append(f'  {f["fold"]}: {", ".join(wb["winners"])} below the population class '
                   f'beyond the 95 % interval. NLL minus the population\'s over held-out '
                   f'blocks of {wb["block_samples"]} samples whose mean lies more than '
                   f'{wb["far_sd"]:g} bias SDs from the population\'s mean '
                   f'({wb["far"]["samples"]} samples): {gains["far"]}; over the others '
                   f'({wb["near"]["samples"]} samples): {gains["near"]}')
        only = (wb.get('pacf') or {}).get('only_in_training')
        if only is not None:
            out.append('    partial autocorrelation beyond 1.96/sqrt(n) in the training part '
                       'and not held out, lags: ' + '; '.join(
                           f'{axis} ' + (','.join(map(str, v)) or 'none')
                           for axis, v in only.items()))
        orders = wb.get('orders') or {}
        if orders.get('train'):
            out.append('    AR order that predicts each 300-s block best from the part\'s '
                       f'others: training part {_orders_text(orders["train"])}; held out '
                       f'{_orders_text(orders.get("held_out"))}')
    return out


def _orders_text(o):
    """Return a part's :func:`~gps_error_ros.judge.beaten.block_orders` in words."""
    if o is None:
        return 'fewer than 3 blocks'
    return f'north {o["north"]["order"]}, east {o["east"]["order"]} ({o["blocks"]} blocks)'


def compare_folds(args, recordings):
    """
    Run the fold comparison; print a table, write ``--json``; return the exit code.

    ``recordings(args, paths=None)`` loads recordings without their gross
    failures (the CLI's loader).
    """
    from gps_error_ros.reports.jsonfile import write_json
    from gps_error_ros.traces.progress import Progress

    if args.zones or args.report:
        raise SystemExit('gps_error compare: --folds and --test write JSON only; '
                         '--zones and --report go with the single 70/30 split')
    smoother = getattr(args, 'smoother', 0)
    if smoother:
        from gps_error_ros.judge.smoother import available, INSTALL
        if not available():
            raise SystemExit(f'gps_error compare: --smoother needs GTSAM, which is not '
                             f'installed: {INSTALL}')
        if smoother > args.sims:
            raise SystemExit(f'gps_error compare: --smoother {smoother}: expected at most '
                             f'--sims ({args.sims}) traces')
    splits = _splits(args, recordings)
    progress = Progress(len(splits), 'judging the classes on', min_total=2)
    try:
        folds = judge_folds(splits, args.sims, args.seed, done=progress.update,
                            smoother_sims=smoother)
    finally:
        progress.close()
    summary = summarise(folds)
    groups = GROUPS + tuple(g for g in EXTRA_GROUPS
                            if any(g in c['groups'] for c in summary.values()))
    print(f'{len(folds)} fold(s): ' + '; '.join(
        f'{f["fold"]} ({f["train_samples"]} train / {f["test_samples"]} held out)'
        for f in folds))
    print(f'  {"class":13} {"NLL":>8} {"best":>5} {"- pop.":>7} {"<,>":>5} ' +
          ' '.join(f'{g[:11]:>11}' for g in groups))
    for name, c in summary.items():
        d = c['nll_minus_population']
        print(f'  {name:13} {c["heldout_nll_per_sample"]:8.3f} {c["best_score_folds"]:5d} '
              f'{d["mean"]:+7.3f} {d["lower_folds"]:>2d},{d["higher_folds"]:<2d} ' +
              ' '.join(f'{c["groups"][g]:11.2f}' if g in c['groups'] else f'{"-":>11}'
                       for g in groups))
    print('  (NLL: held-out NLL per sample, mean over folds; best: folds with the lowest; '
          '- pop.: NLL minus the population class\'s, mean over folds; <,>: folds on which '
          'it is lower, higher beyond its 95 % interval (paired samples, block bootstrap); '
          'groups: share of measures inside their simulated 95 % range, mean over folds)')
    if all('own' in c for c in summary.values()):
        print('  worst group against the class\'s own traces (over the groups every trace '
              'has; own: the median of its own; %: own sets of folds as low or lower; '
              f'bar: own sets with every group >= {GROUP_BAR:.2f}):')
        for name, c in summary.items():
            o = c['own']
            print(f'  {name:13} {o["worst"]:5.2f}  own {o["own_worst_median"]:4.2f}  '
                  f'{o["percentile"]:5.1f} %  bar {o["own_meet_bar"]:5.1f} %')
    for line in beaten_lines(folds):
        print(line)
    for line in (precedent_line(folds), spread_line(folds), velocity_line(folds)):
        if line:
            print(line)
    if args.json_out:
        write_json(Path(args.json_out), {'folds': folds, 'summary': summary,
                                         'sims': args.sims, 'seed': args.seed})
        print(f'wrote {args.json_out}')
    return 0
