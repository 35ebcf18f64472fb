"""
``gps_error``: the command-line tools that need no ROS.

``gps_error calibrate INPUT -o PROFILE.yaml`` fits a profile from a trace CSV
or a rosbag2; ``gps_error validate PROFILE INPUT --out DIR`` cross-validates a
profile against a measured trace; ``gps_error simulate`` adds errors to SUMO
FCD or CSV trajectories, or writes raw error series; ``gps_error diagnose
INPUT`` finds the structure the AR model misses and fits the extended model;
``gps_error compare INPUT`` judges every model class as a simulator of the
held-out data; ``gps_error synth SCENARIO -o WALK.csv`` writes a synthetic
walk; ``gps_error scenario DIR`` builds a georeferenced SUMO walking scenario.
"""

import argparse
import datetime as dt
from collections.abc import Callable, Sequence
from pathlib import Path
import secrets
import sys
from typing import Any, TYPE_CHECKING

from gps_error_ros.cli.inputs import clean_recordings, load_input, load_inputs
from gps_error_ros.cli.parser import build_parser
from gps_error_ros.cli.tables import cmd_split, is_table_input, simulate_table
from gps_error_ros.fit.calibration import calibrate, CalibrationError, little_data_note
from gps_error_ros.fit.gross_failures import failures_doc, find_gross_failures
from gps_error_ros.model.profiles import load_profile_file, ProfileError, write_profile
from gps_error_ros.traces.bag_io import BagError
from gps_error_ros.traces.gnsslogger import GnssLoggerError
from gps_error_ros.traces.gpx import GpxError
from gps_error_ros.traces.landmarks import LandmarkError
from gps_error_ros.traces.nmea import NmeaError
from gps_error_ros.traces.pairing import PairingError
from gps_error_ros.traces.progress import stage_progress
from gps_error_ros.traces.trace_io import Trace, TraceError

if TYPE_CHECKING:
    from gps_error_ros.diagnose.pipeline import Diagnosis
    from gps_error_ros.fit.holdout import Split

# DiagnosisError is a ValueError
ERRORS = (TraceError, BagError, PairingError, CalibrationError, ProfileError,
          NmeaError, GnssLoggerError, GpxError, LandmarkError, ValueError, OSError)


def cmd_simulate(args: argparse.Namespace) -> int:
    """Run ``gps_error simulate``; return the exit code."""
    from gps_error_ros.sim import simulate as batch
    from gps_error_ros.model.about_truth import model_about_truth, reported_mean
    from gps_error_ros.model.profiles import load_profile

    _check_simulate_modes(args)
    profile = load_profile(args.profile)
    zones = None
    # covariances about the truth; reported: the phone's radius, the mean added after
    about = model_about_truth(args.covariance_about, args.covariance_mode) \
        and bool(args.trajectories)
    if args.zones:
        from gps_error_ros.model.zoned import zoned_errors
        from gps_error_ros.model.zones import load_zone_map
        if not args.trajectories:
            raise ValueError('--zones needs --trajectories: the raw mode (--agents) '
                             'has no positions to place in zones')
        profile, model, zones = zoned_errors(load_zone_map(args.zones), profile,
                                             args.covariance_mode, about)
    else:
        model = profile.model(about_truth=about)
    bias = reported_mean(model, args.covariance_about)
    if args.covariance_mode == 'reported' and profile.reported_accuracy is None:
        raise ValueError(f'--covariance-mode reported: profile {profile.name} '
                         f'({profile.path}) has no reported_accuracy section; calibrate '
                         f'one from a trace with an accuracy or hdop column, or choose '
                         f'stationary or conditional')
    if args.seed == -1:
        args.seed = secrets.randbits(63)
        print(f'no seed given: using seed {args.seed}')
    faults = _faults(args)
    if args.trajectories and is_table_input(Path(args.trajectories)):
        res = simulate_table(args, model, profile, bias, faults, zones)
    elif args.trajectories:
        src = Path(args.trajectories)
        if Path(args.out).suffix.lower() == '.nmea':
            if src.suffix.lower() != '.csv':
                raise ValueError(f'--out {args.out}: NMEA output takes a trajectories '
                                 f'CSV of one agent, got {src.name}')
            utc0 = args.utc_start or dt.datetime(1970, 1, 1, tzinfo=dt.timezone.utc)
            res = batch.simulate_nmea(src, args.out, model, profile.rate_hz, args.seed, utc0,
                                      profile.velocity, args.covariance_mode, zones,
                                      profile.reported_accuracy, bias, faults)
        elif src.suffix.lower() == '.csv':
            res = batch.simulate_csv(src, args.out, model, profile.rate_hz, args.seed,
                                     profile.velocity, args.covariance_mode, zones,
                                     profile.reported_accuracy, bias, faults)
        else:
            res = batch.simulate_fcd(src, args.out, model, profile.rate_hz,
                                     args.seed, args.net, args.coordinates, args.digits,
                                     zones, args.covariance_mode,
                                     profile.reported_accuracy, profile.velocity, bias, faults,
                                     args.errors)
    else:
        res = batch.simulate_npz(args.out, model, profile.rate_hz, args.seed,
                                 args.agents, args.duration, args.start)
    print(', '.join(f'{v} {k}' for k, v in res.items()) + f'; wrote {args.out}')
    return 0


def _check_simulate_modes(args: argparse.Namespace) -> None:
    """Refuse ``simulate``'s options that name no mode, or two, or an output nowhere."""
    if args.trajectories and (args.agents is not None or args.duration is not None):
        raise ValueError('--trajectories and --agents/--duration are two modes: '
                         'give one of them')
    if not args.trajectories and (args.agents is None or args.duration is None):
        raise ValueError('expected --trajectories INPUT, or --agents N and '
                         '--duration S')
    _check_output_dir(args.out, '--out')


def _faults(args: argparse.Namespace) -> list[Any]:
    """Return the faults of ``--faults`` (none without it); refuse the modes without them."""
    if args.faults is None:
        return []
    from gps_error_ros.sim.faults import load_schedule
    if not args.trajectories:
        raise ValueError(f'--faults {args.faults}: faults are laid over the fixes of '
                         f'trajectories (--trajectories); the raw mode (.npz) has none')
    return load_schedule(args.faults)


def _check_output_dir(path: str, option: str) -> None:
    """Refuse an output whose directory does not exist, before any work."""
    parent = Path(path).expanduser().resolve().parent
    if not parent.is_dir():
        raise ValueError(f'{option} {path}: directory {parent} does not exist')


def cmd_validate(args: argparse.Namespace) -> int:
    """Run ``gps_error validate``; return the exit code (:mod:`.validate`)."""
    from gps_error_ros.cli.validate import run_validate
    return run_validate(args)


def cmd_calibrate(args: argparse.Namespace) -> int:
    """Run ``gps_error calibrate``; return the exit code."""
    if args.zones:
        from gps_error_ros.cli.zones import calibrate_per_zone
        return calibrate_per_zone(args, load_input)
    _check_output_dir(args.output, '-o')
    if args.within is not None and not args.population:
        raise ValueError(f'--within {args.within} is the process within a population\'s '
                         f'blocks: add --population, or leave --within out')
    extended = args.population and args.within != 'ar'
    if extended and args.order is not None:
        raise ValueError(f'--order {args.order} fixes the Gaussian AR\'s order; the extended '
                         f'model within a population chooses its own by the PACF: add '
                         f'--within ar to fix it')
    traces = load_inputs(args)
    if extended:
        from gps_error_ros.judge.population_calibration import calibrate_best, STAGES
        progress = stage_progress([len(t) for t in traces], [t.name for t in traces], STAGES,
                                  'fitting the extended model within')
        try:
            result = calibrate_best(traces, args.day_allowance, args.seed, progress.update)
        finally:
            progress.close()
    else:
        result = calibrate(traces, order=args.order, max_order=args.max_order,
                           population=args.population, day_allowance=args.day_allowance)
    out = Path(args.output)
    profile = result.profile_dict(args.name or out.stem)
    write_profile(out, profile)
    load_profile_file(out)          # what we write must load as it is
    for found in result.failures:
        print(found.describe())
    print(result.summary(max_order=args.max_order))
    note = little_data_note(result)
    if note:        # diagnose's sizes; its package is imported only for this line
        from gps_error_ros.diagnose.common import MIN_TEST, MIN_TRAIN
        print(f'  note: {note} (compare and diagnose need {MIN_TRAIN} to train on and '
              f'{MIN_TEST} held out, of 70 and 30 %)')
    print(f'wrote {out}')
    return 0


def cmd_diagnose(args: argparse.Namespace) -> int:
    """Run ``gps_error diagnose``; return the exit code."""
    from gps_error_ros.diagnose import diagnose
    from gps_error_ros.diagnose.pipeline import STAGES
    from gps_error_ros.reports.diagnosis_figure import diagnosis_figure

    if args.population and not args.profile_out:
        raise SystemExit('gps_error diagnose: --population goes with --profile-out '
                         '(it chooses the profile written)')
    for option, path in (('--json', args.json_out), ('--profile-out', args.profile_out)):
        if path:
            _check_output_dir(path, option)
    recordings = load_inputs(args)
    progress = stage_progress([len(t) for t in recordings], [t.name for t in recordings],
                              STAGES, 'diagnosing')
    try:
        # the library finds each recording's gross failures and leaves them out
        diag = diagnose(recordings, sims=args.sims, seed=args.seed, done=progress.update)
    finally:
        progress.close()
    for found in diag.fitted.failures:
        print(found.describe())
    print(diag.summary())
    _write_results(args, diag.to_dict(), 'diagnosis.png',
                   lambda path: diagnosis_figure(diag, path, diag.findings.input))
    if args.profile_out:
        _write_diagnosed_profile(args, diag)
    return 0


def _write_diagnosed_profile(args: argparse.Namespace, diag: 'Diagnosis') -> None:
    """Write ``diagnose --profile-out``: the extended profile, or with ``--population`` that."""
    from gps_error_ros.diagnose import extended_profile
    out, source = Path(args.profile_out), diag.findings.input
    prof = extended_profile(diag, out.stem, source)
    if args.population:
        from gps_error_ros.judge.generalise import population_profile
        pop = population_profile(diag.split, out.stem, source, args.seed)
        blocks = pop['fit']['population']['blocks']
        if 'population' in pop:
            print(f'  population: {pop["population"]} ({blocks} training blocks of 300 s)')
            prof = pop
        else:                           # no spread to fit: the whole part's fit
            print(f'  population: none ({blocks} training block(s) of 300 s, 3 needed): '
                  f'the extended profile is written')
    write_profile(out, prof, 'diagnose')
    load_profile_file(out)              # what we write must load as it is
    print(f'wrote {out}')


def _write_results(args: argparse.Namespace, doc: Any, figure_name: str,
                   draw: Callable[[Path], object]) -> None:
    """Write ``doc`` to ``--json`` and ``draw(path)`` into ``--report``, if asked."""
    from gps_error_ros.reports.jsonfile import write_json
    if args.json_out:
        write_json(Path(args.json_out), doc)
        print(f'wrote {args.json_out}')
    if args.report:
        out = Path(args.report)
        out.mkdir(parents=True, exist_ok=True)
        draw(out / figure_name)
        print(f'wrote {out / figure_name}')


def cmd_compare(args: argparse.Namespace) -> int:
    """Run ``gps_error compare``; return the exit code."""
    if args.folds or args.test:
        from gps_error_ros.cli.folds import compare_folds
        return compare_folds(args, clean_recordings)
    if args.smoother:
        raise SystemExit('gps_error compare: --smoother goes with --folds or --test '
                         '(the groups of measures); the single 70/30 split has none')
    from gps_error_ros.judge.baselines import compare, split_comparison
    from gps_error_ros.diagnose.pipeline import fit_models, STAGES
    from gps_error_ros.reports.compare_figure import compare_figure

    if args.json_out:
        _check_output_dir(args.json_out, '--json')
    recordings = load_inputs(args)
    progress = stage_progress([len(t) for t in recordings], [t.name for t in recordings],
                              STAGES - 2, 'fitting the classes of')
    try:
        # the held-out simulation is compare's; the library leaves the failures out
        fitted = fit_models(recordings, done=progress.update)
    finally:
        progress.close()
    for found in fitted.failures:
        print(found.describe())
    result = split_comparison(fitted.name, fitted.split,
                              compare(fitted, sims=args.sims, seed=args.seed), args.sims)
    result.gross_failures = failures_doc(fitted.failures)
    print(result.summary())
    if args.zones:
        result.zones = _compare_zones(args, recordings[0], fitted.split)
    doc = result.to_dict()
    _write_results(args, doc, 'compare.png', lambda path: compare_figure(doc, path))
    return 0


def _compare_zones(args: argparse.Namespace, trace: Trace, split: 'Split') -> dict[str, Any]:
    """Return one profile against a profile per zone; print it."""
    from gps_error_ros.judge.zoned_compare import compare_zones
    from gps_error_ros.model.zones import load_zone_map

    origin = (float(trace.truth_lat[0]), float(trace.truth_lon[0]))
    z = compare_zones(split, load_zone_map(args.zones), origin, sims=args.sims, seed=args.seed)
    print(f'  zones of {args.zones} (Yule-Walker profiles, as calibrate and '
          f'calibrate --zones write them):')
    for name, c in z['classes'].items():
        print(f'  {name:12} {c["heldout_nll_per_sample"]:13.4f} '
              f'{c["fidelity"]["inside_95"]:10.2f}')
    imp = z['nll_improvement']
    print(f'  per zone lowers the held-out NLL by {imp["per_sample"]:.4f} per sample '
          f'(95 % CI {imp["ci95"][0]:.4f} .. {imp["ci95"][1]:.4f})')
    for name, e in z['zones'].items():
        fitted = 'own profile' if e.get('fitted') else f'one profile ({e.get("reason", "")})'
        held = (f'; held out {e["heldout_samples"]}: NLL one {e["heldout_nll_one_profile"]:.4f},'
                f' per zone {e["heldout_nll_per_zone"]:.4f}' if 'heldout_samples' in e else '')
        print(f'    {name}: {fitted}{held}')
    return z


def cmd_import(args: argparse.Namespace) -> int:
    """Run ``gps_error import``; return the exit code."""
    from gps_error_ros.traces.importing import import_recording
    from gps_error_ros.traces.trace_io import write_trace_csv

    _check_output_dir(args.output, '-o')
    landmarks = args.landmarks is not None or args.passes is not None
    if landmarks == (args.truth is not None) or \
            (landmarks and (args.landmarks is None or args.passes is None)):
        raise ValueError('expected --truth TRUTH, or --landmarks FILE and --passes FILE')
    truth = (args.landmarks, args.passes) if landmarks else args.truth
    trace, notes = import_recording(args.format, args.input, truth,
                                    args.max_truth_gap, args.provider, args.truth_date)
    for line in notes:
        print(line)
    print(find_gross_failures(trace).describe(kept_out=False))
    write_trace_csv(trace, args.output)
    print(f'wrote {args.output}: {len(trace)} rows')
    return 0


def cmd_synth(args: argparse.Namespace) -> int:
    """Run ``gps_error synth``; return the exit code."""
    from gps_error_ros.sim.synthetic import synthetic_trace
    from gps_error_ros.traces.trace_io import write_trace_csv

    _check_output_dir(args.output, '-o')
    trace = synthetic_trace(args.scenario, args.seed, args.duration)
    write_trace_csv(trace, args.output)
    print(f'wrote {args.output}: {len(trace)} fixes, scenario {args.scenario}, '
          f'seed {args.seed}')
    return 0


def cmd_scenario(args: argparse.Namespace) -> int:
    """Run ``gps_error scenario``; return the exit code."""
    from gps_error_ros.sim import sumo_scenario as sumo

    try:
        sc = sumo.build_grid_scenario(args.out, grid=args.grid, length=args.length,
                                      depart_until=args.until, period=args.period,
                                      seed=args.seed, lat=args.lat, lon=args.lon)
        print(f'wrote {sc.sumocfg} ({sc.net.name}: {args.grid} x {args.grid} junctions '
              f'{args.length:g} m apart at {args.lat}, {args.lon}; {sc.routes.name}: '
              f'{len(sc.persons)} persons)')
        run = [sumo.sumo_tool('sumo'), '-c', str(sc.sumocfg), '--fcd-output',
               str(sc.sumocfg.parent / 'fcd.xml'), '--fcd-output.geo', 'true']
        if args.fcd is None:
            print('SUMO, for positions in lon/lat: ' + ' '.join(run) + ' --end SECONDS')
            return 0
        sumo._run(run + ['--end', f'{sc.begin + args.fcd:g}'], 'sumo', sc.sumocfg.parent)
    except (sumo.SumoMissing, RuntimeError) as exc:
        raise ValueError(str(exc)) from None
    print(f'wrote {sc.sumocfg.parent / "fcd.xml"} (lon/lat): gps_error simulate --profile DS5 '
          f'--trajectories {sc.sumocfg.parent / "fcd.xml"} --out noisy.xml')
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``gps_error``."""
    args = build_parser().parse_args(argv)
    try:
        return {'calibrate': cmd_calibrate, 'validate': cmd_validate,
                'simulate': cmd_simulate, 'diagnose': cmd_diagnose,
                'compare': cmd_compare, 'import': cmd_import,
                'synth': cmd_synth, 'scenario': cmd_scenario,
                'split': cmd_split}[args.command](args)
    except ERRORS as exc:
        print(f'gps_error {args.command}: {exc}', file=sys.stderr)
        return 2
