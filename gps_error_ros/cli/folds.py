"""``gps_error compare --folds`` and ``--test``: the classes across stretches and recordings."""

import argparse
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from gps_error_ros.fit.holdout import Split
from gps_error_ros.fit.gross_failures import GrossFailures
from gps_error_ros.fit.population_fit import segment_weights
from gps_error_ros.judge.fold_summary import compare_on_folds
from gps_error_ros.judge.generalise import recording_splits, rolling_splits, split_between
from gps_error_ros.traces.trace_io import join_recordings, Trace

#: The CLI's loader: ``recordings(args, paths=None)``, the traces without their gross
#: failures, and the failures (:func:`gps_error_ros.cli.clean_recordings`).
Loader = Callable[..., tuple[list[Trace], list[GrossFailures]]]


def _splits(args: argparse.Namespace, recordings: Loader) -> list[tuple[str, Split]]:
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


def compare_folds(args: argparse.Namespace, recordings: Loader) -> int:
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
        result = compare_on_folds(splits, args.sims, args.seed, done=progress.update,
                                  smoother_sims=smoother)
    finally:
        progress.close()
    print(result.summary())
    if args.json_out:
        write_json(Path(args.json_out), result.to_dict())
        print(f'wrote {args.json_out}')
    return 0
