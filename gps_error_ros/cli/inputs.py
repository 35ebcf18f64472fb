"""
The commands' recordings: loaded, their gross failures found, and the options that pick a part.

Shared by the commands of :mod:`gps_error_ros.cli` and :mod:`gps_error_ros.cli.validate`.
"""

import argparse
from collections.abc import Sequence

from gps_error_ros.fit.calibration import check_sampling
from gps_error_ros.fit.gross_failures import (find_gross_failures, GrossFailures,
                                              without_gross_failures)
from gps_error_ros.model.profiles import Profile
from gps_error_ros.traces.loading import expand_inputs, load_trace, parse_datum
from gps_error_ros.traces.trace_io import join_recordings, Trace


def load_inputs(args: argparse.Namespace, paths: Sequence[str] | None = None) -> list[Trace]:
    """
    Load every INPUT (or ``paths``: files, or folders of them); print how it went.

    A recording sampled slower than the 1-Hz grid is refused (:func:`check_sampling`).
    """
    traces: list[Trace] = []
    for path in expand_inputs(args.input if paths is None else paths):
        trace, notes = load_trace(path, args.fix_topic, args.truth_topic,
                                  parse_datum(args.datum), args.max_truth_gap, args.agent)
        for line in notes:
            print(line)
        check_sampling(trace)
        traces.append(trace)
    return traces


def load_input(args: argparse.Namespace) -> Trace:
    """Return :func:`load_clean`'s trace alone."""
    return load_clean(args)[0]


def clean_recordings(args: argparse.Namespace, paths: Sequence[str] | None = None,
                     mark: str | None = None) -> tuple[list[Trace], list[GrossFailures]]:
    """
    Return the INPUTs (or ``paths``) without their gross failures, and the failures.

    Each recording's are found on its own, printed, and left out (with
    ``mark``: kept and flagged 1.0 in the extra column of that name).
    """
    loaded = load_inputs(args, paths)
    if mark:
        found = [find_gross_failures(trace) for trace in loaded]
        for trace, f in zip(loaded, found):
            trace.extra[mark] = f.mask.astype(float)
        traces = loaded
    else:
        traces, found = without_gross_failures(loaded)
    for f in found:
        print(f.describe())
    return traces, found


def load_clean(args: argparse.Namespace,
               mark: str | None = None) -> tuple[Trace, list[GrossFailures]]:
    """Return :func:`clean_recordings` joined into one trace (:func:`join_recordings`)."""
    traces, found = clean_recordings(args, mark=mark)
    return join_recordings(traces), found


def failure_check(profile: Profile, found: Sequence[GrossFailures]) -> str:
    """
    Return a line: the failures measured against the profile's rate (95 % range).

    Binomial for one rate; with the section's ``rate_sd_log`` each recording
    is an agent with a rate of its own, and the range is their total's.
    """
    from scipy import stats
    count, fixes = sum(f.count for f in found), sum(f.rows for f in found)
    process = profile.gross_failures
    rate = process.rate if process is not None else 0.0
    said = f'the profile\'s rate {rate:.4g}'
    if process is None or not process.rate_sd_log:
        lo, hi = (int(v) for v in stats.binom.ppf([0.025, 0.975], fixes, rate))
    else:
        lo, hi = process.count_range([f.rows for f in found])
        said += f' (each recording\'s own, log SD {process.rate_sd_log:.2g})'
    inside = 'inside' if lo <= count <= hi else 'OUTSIDE'
    return (f'  gross failures: measured {count} of {fixes} fixes; {said} gives '
            f'{lo}-{hi} (95 %): {inside}')


def part_of(text: str) -> tuple[float, float]:
    """Return ``--part START,END`` as two fractions of the time span."""
    try:
        lo, hi = (float(v) for v in text.split(','))
    except ValueError:
        raise ValueError(f'--part {text!r}: expected START,END fractions') from None
    if not 0.0 <= lo < hi <= 1.0:
        raise ValueError(f'--part {text!r}: expected 0 <= START < END <= 1')
    return lo, hi
