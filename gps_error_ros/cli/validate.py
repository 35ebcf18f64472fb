"""
``gps_error validate``: a profile's simulated traces against measured recordings.

Pooled (one trace of every recording, the default) or, with ``--each``,
each recording on its own and the recordings judged together by occasion
(:func:`~gps_error_ros.fit.validation.family_verdict`).
"""

import argparse
from pathlib import Path
from typing import Any

from gps_error_ros.cli.inputs import clean_recordings, failure_check, load_clean, part_of
from gps_error_ros.fit.population_fit import occasions
from gps_error_ros.fit.validation import (FAILURE_COLUMN, family_verdict, slice_trace,
                                          summary_lines, validate)
from gps_error_ros.model.profiles import load_profile, Profile
from gps_error_ros.reports.jsonfile import write_json
from gps_error_ros.reports.validation_figure import validation_figure
from gps_error_ros.traces.trace_io import Trace


def _validate_one(args: argparse.Namespace, profile: Profile, model: Any, zones: Any, trace: Trace,
                  out: Path, part: tuple[float, float]) -> dict[str, Any]:
    """Validate ``model`` on ``trace``, write ``out``'s JSON and figure; return the summary."""
    lo, hi = part
    res = validate(model, trace, sims=args.sims, max_lag=args.max_lag,
                   seed=args.seed, zones=zones, reported=profile.reported_accuracy)
    out.mkdir(parents=True, exist_ok=True)
    summary = res.to_dict()
    summary.update({'profile': args.profile, 'part': [lo, hi]})
    write_json(out / 'validation.json', summary)
    validation_figure(res, out / 'validation.png',
                      f'{args.profile} against {trace.name} '
                      f'(part {lo:g}-{hi:g}, {res.samples} samples)')
    return summary


def _validate_each(args: argparse.Namespace, profile: Profile, model: Any, zones: Any,
                   part: tuple[float, float]) -> int:
    """``validate --each``: every recording on its own, then the recordings as a family."""
    traces, found = clean_recordings(args, mark=FAILURE_COLUMN)
    lo, hi = part
    out, joint, names = Path(args.out), [], []
    for i, whole in enumerate(traces):
        trace = slice_trace(whole, lo, hi)
        name = f'{i:02d}-{Path(whole.name).stem}'
        summary = _validate_one(args, profile, model, zones, trace, out / name, part)
        n, e = summary['north'], summary['east']
        joint.append(summary['shares_joint_percentile'])
        names.append(whole.name)
        print(f'  {whole.name}: ACF inside {100 * n["acf_lags_inside_envelope"]:.0f} / '
              f'{100 * e["acf_lags_inside_envelope"]:.0f} % (north / east), quantiles '
              f'{100 * n["quantiles_inside_envelope"]:.0f} / '
              f'{100 * e["quantiles_inside_envelope"]:.0f} %; the four shares together: '
              f'percentile {joint[-1]:.1f} (in {out / name})')
    labels = occasions(traces)
    fam = family_verdict(joint, labels)
    write_json(out / 'family.json', {
        'profile': args.profile, 'part': [lo, hi],
        'recordings': [{'name': n, 'occasion': int(o), 'shares_joint_percentile': p}
                       for n, o, p in zip(names, labels, joint)], **fam})
    k = fam['occasions']
    print(f'  as a family: {k} occasion(s) (recordings made together count once, at their '
          f'smallest), the smallest joint percentile {fam["smallest_percentile"]:.1f}: among '
          f'{k} occasion(s) drawn from the model, one as low or lower turns up '
          f'{100 * fam["family_probability"]:.0f} % of the time (Sidak), so the recordings '
          'together are '
          + ('UNLIKE' if fam['unlike'] else 'not unlike') +
          ' the model\'s traces at the 5 % level')
    print(failure_check(profile, found))
    print(f'wrote {out / "family.json"} and a directory per recording')
    return 0


def profile_class(profile: Profile) -> str:
    """
    Return a line: which class of model the profile is, and the best one on held-out days.

    On held-out days and walks the population with the extended model within
    predicted best (docs/generalisation.md); a user should know whether the
    profile at hand is that class, and how to get it if not.
    """
    effects = profile.effects.names
    if profile.population is not None and effects:
        return ('  profile class: a population (each agent its own bias and scale) with the '
                'extended model within (' + ', '.join(effects) + '): the class that predicted '
                'best on held-out days and walks')
    if profile.population is not None:
        return ('  profile class: a population with a Gaussian AR within; the population with '
                'the extended model within predicted better on held-out days and walks: '
                'gps_error calibrate RECORDINGS --population -o BEST.yaml')
    within = 'the extended model (' + ', '.join(effects) + ')' if effects else 'one AR process'
    return (f'  profile class: {within} for every agent, no population; a population with '
            f'the extended model within predicted better on held-out days and walks: '
            f'gps_error calibrate RECORDINGS --population -o BEST.yaml')


def run_validate(args: argparse.Namespace) -> int:
    """Run ``gps_error validate``; return the exit code."""
    lo, hi = part_of(args.part)
    profile, zones = load_profile(args.profile), None
    if args.zones:
        from gps_error_ros.model.zoned import zoned_errors
        from gps_error_ros.model.zones import load_zone_map
        profile, model, zones = zoned_errors(load_zone_map(args.zones), profile)
    else:
        # the measured failures are left out, so the simulated ones are too
        model = profile.model(gross_failures=False)
    if args.each:
        return _validate_each(args, profile, model, zones, (lo, hi))
    whole, found = load_clean(args, mark=FAILURE_COLUMN)
    trace = slice_trace(whole, lo, hi)
    out = Path(args.out)
    summary = _validate_one(args, profile, model, zones, trace, out, (lo, hi))
    print('\n'.join(summary_lines(summary)))
    print(failure_check(profile, found))
    print(profile_class(profile))
    print(f'wrote {out / "validation.png"} and {out / "validation.json"}')
    return 0
