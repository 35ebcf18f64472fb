"""The ``gps_error`` command line: its parser, one builder per command."""

import argparse
from collections.abc import Callable
import datetime
from typing import TYPE_CHECKING, TypeAlias

from gps_error_ros.fit.population_fit import DAY_RATIO
from gps_error_ros.fit.yule_walker import DEFAULT_MAX_ORDER
from gps_error_ros.model.ar_model import MAX_ORDER

if TYPE_CHECKING:
    #: What ``add_subparsers`` returns: each command's builder adds its parser to it
    #: (generic to the type checker only).
    Subparsers: TypeAlias = argparse._SubParsersAction[argparse.ArgumentParser]


def number(kind: type[int] | type[float], lo: float | None = None, hi: float | None = None,
           lo_open: bool = False) -> Callable[[str], float]:
    """
    Return an argparse type: ``kind`` (int or float) in [lo, hi].

    argparse turns its ValueError into "argument --X: invalid value" with the
    reason, exit 2, before anything runs.
    """
    def parse(text: str) -> float:
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f'{text!r}: expected {"an integer" if kind is int else "a number"}') from None
        if kind is float and v != v:
            raise argparse.ArgumentTypeError(f'{text!r}: expected a number')
        below = lo is not None and (v <= lo if lo_open else v < lo)
        if below or (hi is not None and v > hi):
            lo_text = '' if lo is None else ('> ' if lo_open else '>= ') + f'{lo:g}'
            hi_text = '' if hi is None else f'<= {hi:g}'
            raise argparse.ArgumentTypeError(
                f'{text}: expected a value {" and ".join(t for t in (lo_text, hi_text) if t)}')
        return v
    return parse


def _date(text: str) -> datetime.date:
    """Return a ``datetime.date`` of 'YYYY-MM-DD' (an argparse type)."""
    import datetime as dt
    try:
        return dt.date.fromisoformat(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text!r}: expected YYYY-MM-DD') from None


def _utc(text: str) -> datetime.datetime:
    """Return a UTC ``datetime`` of 'YYYY-MM-DDTHH:MM:SS' (an argparse type)."""
    try:
        t = datetime.datetime.fromisoformat(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text!r}: expected YYYY-MM-DDTHH:MM:SS') from None
    return t.replace(tzinfo=datetime.timezone.utc) if t.tzinfo is None else t


#: Simulated traces an envelope needs: its 2.5 and 97.5 % points must be
#: estimable (with fewer, the central 95 % range is the sample's extremes).
MIN_SIMS = 20


def _add_input_options(p: argparse.ArgumentParser) -> None:
    p.add_argument('--fix-topic', default='/fix',
                   help='bag input: topic of the measured sensor_msgs/NavSatFix '
                        '(default /fix)')
    p.add_argument('--truth-topic', default='/pose',
                   help='bag input: ground-truth topic, PoseStamped, Odometry or '
                        'NavSatFix, detected from the bag (default /pose)')
    p.add_argument('--datum', default=None,
                   help='bag input with pose/odometry truth: LAT,LON[,ALT] of '
                        'the truth frame\'s origin')
    p.add_argument('--agent', default=None,
                   help='trace CSV with an agent column (as gps_error simulate '
                        'writes): the agent to use (required when it holds more '
                        'than one)')
    p.add_argument('--max-truth-gap', type=number(float, 0.0, lo_open=True), default=None,
                   help='bag input: longest truth interval (s) bridged by '
                        'interpolation (default 3 x the median, >= 1.5 s)')


def _scenarios() -> list[str]:
    from gps_error_ros.sim.synthetic import SCENARIOS
    return list(SCENARIOS)


def _add_calibrate(sub: 'Subparsers') -> None:
    c = sub.add_parser(
        'calibrate', help='fit a profile from a measured trace',
        description='Fit an AR profile (schema 1, with a fit section) to the '
                    'errors of a measured trace against its ground truth. '
                    'INPUT is a trace CSV (columns t, lat, lon, truth_lat, '
                    'truth_lon; see data/README.md in the repository) or a rosbag2 '
                    '(MCAP or SQLite3) with fixes and truth.')
    c.add_argument('input', nargs='+',
                   help='trace CSV or rosbag2 directory; several, or a folder of them, '
                        'are recordings of one receiver (each keeps its own segments)')
    _add_input_options(c)
    c.add_argument('-o', '--output', required=True,
                   help='profile YAML to write (with --zones: a directory)')
    c.add_argument('--zones', default=None,
                   help='zone map (GeoJSON): fit one profile per zone with at least 300 '
                        'samples into the directory -o, the whole trace into all.yaml '
                        '(the fallback of the other zones and the default outside), and '
                        'write zones.geojson that references them (needs shapely)')
    c.add_argument('--order', type=number(int, 1, MAX_ORDER), default=None,
                   help='fix the AR order (default: chosen per axis by the PACF)')
    c.add_argument('--max-order', type=number(int, 1, MAX_ORDER), default=DEFAULT_MAX_ORDER,
                   help=f'largest order the PACF may choose (default '
                        f'{DEFAULT_MAX_ORDER})')
    c.add_argument('--name', default=None,
                   help='profile name (default: the output file stem)')
    c.add_argument('--population', action='store_true',
                   help='describe the receiver across stretches, the class that predicted '
                        'best on held-out days: a population section (each simulated agent '
                        'draws its own bias and scale, as blocks of 300 s and recordings '
                        'differ; with 3 recordings or more, its own gross-failure rate '
                        'too) and, within the blocks, the extended model of diagnose '
                        '(see --within); needs 3 blocks of 300 s, e.g. 15 min of data or '
                        'several recordings; not with --zones (a zone map takes the '
                        'population of its default_profile)')
    c.add_argument('--within', choices=('extended', 'ar'), default=None,
                   help='with --population, the process within the blocks: extended (the '
                        'default: the AR with the effects diagnose keeps, chosen by blocked '
                        'cross-validation; slower, about 25 s for 30 min of data) or ar '
                        '(the Gaussian AR, its order from the PACF or --order; the bias '
                        'split into a part held for a run and a wander where the '
                        'recordings hold two runs or more)')
    c.add_argument('--seed', type=number(int, 0, 2 ** 32 - 1), default=0,
                   help='with --population: the seed of the effect selection\'s '
                        'simulations (default 0)')
    c.add_argument('--day-allowance', type=number(float, 0.0, 10.0), default=DAY_RATIO,
                   metavar='RATIO',
                   help='with --population from one occasion (one recording, or several '
                        'made together): add a part of the bias held for the run, its SD '
                        'RATIO times the blocks\' bias SD, for days the recording did not '
                        f'see (default {DAY_RATIO:g}, from recordings of several days; 0: '
                        'none)')


def _add_validate(sub: 'Subparsers') -> None:
    v = sub.add_parser(
        'validate', help='cross-validate a profile against a measured trace',
        description='Simulate many traces of the measured trace\'s length and '
                    'time grid with PROFILE and compare: autocorrelation per '
                    'lag against the Monte-Carlo 95 % envelope, quantiles per '
                    'axis (QQ) with envelopes, and a map. Writes '
                    'DIR/validation.png and DIR/validation.json.')
    v.add_argument('profile', help='profile: a built-in name (DS1, DS2, DS5, DS7, '
                                   'phone-suburban-drive, snapshot-receiver-on-foot) or a '
                                   'profile YAML path')
    v.add_argument('input', nargs='+',
                   help='trace CSV or rosbag2 directory; several, or a folder of them, '
                        'are recordings of one receiver')
    v.add_argument('--zones', default=None,
                   help='zone map (GeoJSON): simulate with each zone\'s profile where the '
                        'truth is (PROFILE outside, unless the map has a default_profile) '
                        'and check each zone\'s samples alone too (needs shapely)')
    v.add_argument('--out', required=True, help='output directory')
    v.add_argument('--sims', type=number(int, MIN_SIMS), default=200,
                   help='Monte-Carlo runs (default 200)')
    v.add_argument('--max-lag', type=number(int, 1), default=60,
                   help='largest autocorrelation lag, s (default 60)')
    v.add_argument('--part', default='0,1',
                   help='the part of the trace to validate on, as fractions of '
                        'its duration START,END (default 0,1; e.g. 0.7,1 for '
                        'the last 30 %% held out from a fit on 0,0.7)')
    v.add_argument('--seed', type=number(int, 0, 2 ** 64 - 1), default=0,
                   help='simulation seed')
    v.add_argument('--each', action='store_true',
                   help='several recordings: validate each on its own (DIR/NN-NAME/) '
                        'instead of pooled, and judge them as a family: the smallest '
                        'joint percentile over their occasions (recordings made together '
                        'count once), Sidak-adjusted for their number (DIR/family.json)')
    _add_input_options(v)


def _add_simulate(sub: 'Subparsers') -> None:
    s = sub.add_parser(
        'simulate', help='add errors to trajectories, or write raw error series',
        description='Smartphone GPS errors for simulators that do not run ROS, '
                    'with the error node\'s per-agent streams. Either '
                    '--trajectories INPUT (SUMO FCD output as XML or Parquet, or a CSV '
                    'with t, truth_lat, truth_lon and optional agent) --out OUTPUT in '
                    'the same format with noisy positions (a CSV also keeps the '
                    'true ones; a CSV of one agent can go to --out FIXES.nmea: NMEA '
                    '0183 GGA, GSA, GST and RMC, as a receiver streams them), or '
                    '--agents N --duration S --out ERRORS.npz.')
    s.add_argument('--profile', default='DS5', help='profile name or YAML (default DS5)')
    s.add_argument('--seed', type=number(int, -1, 2 ** 64 - 1), required=True,
                   help='seed of the error streams (as the node\'s; -1: draw one '
                        'and print it)')
    s.add_argument('--out', required=True, help='output file')
    s.add_argument('--trajectories', help='SUMO FCD .xml or .parquet, a directory of Parquet '
                                          'parts (gps_error split), or a truth CSV')
    s.add_argument('--net', help='SUMO .net.xml for FCD x/y written without '
                                 '--fcd-output.geo')
    s.add_argument('--coordinates', choices=('lonlat', 'xy'), default=None,
                   help='FCD positions are lon/lat or x/y metres; default: what '
                        'SUMO\'s options comment at the top of the file says '
                        '(required for a file without it; Parquet has none: x/y '
                        'metres with --net, else required)')
    s.add_argument('--covariance-mode', choices=('stationary', 'conditional', 'reported'),
                   default='stationary',
                   help='the covariance behind each position\'s accuracy, accuracy_major, '
                        'accuracy_minor, accuracy_orientation (CSV columns, FCD '
                        'attributes), as the node\'s covariance_mode (default stationary; '
                        'reported: the radius the profile\'s reported_accuracy states)')
    s.add_argument('--covariance-about', choices=('truth', 'mean'), default='truth',
                   help='what that covariance covers, as the node\'s covariance_about: '
                        'truth (default), the error about the truth, its mean included '
                        '(C + m m^T); mean, its spread about its mean alone (C). The '
                        'accuracy attribute in reported mode stays what the phone states')
    s.add_argument('--zones', default=None,
                   help='zone map (GeoJSON polygons with a "profile" property): each '
                        'agent gets the error process of the zone its truth is in, '
                        'step by step; --profile applies outside every zone unless the '
                        'map names a default_profile (needs the extra "zones": shapely)')
    s.add_argument('--faults', default=None, metavar='SCHEDULE.yaml',
                   help='fault schedule (YAML; as the node\'s fault_schedule, times on the '
                        'trajectories\' t): outages, frozen fixes, offsets, degraded '
                        'stretches and gross failures on chosen agents at chosen times; '
                        'every trajectory mode (FCD: with lon/lat or a georeferenced net)')
    _add_simulate_fcd(s)
    s.add_argument('--utc-start', type=_utc, default=None,
                   help='NMEA output: the UTC time of t = 0 in the trajectories, '
                        'YYYY-MM-DDTHH:MM:SS (default 1970-01-01T00:00:00: t is Unix '
                        'time)')
    s.add_argument('--agents', type=number(int, 1),
                   help='raw mode: number of agents, named agent0, agent1, ...')
    s.add_argument('--duration', type=number(float, 0.0, lo_open=True),
                   help='raw mode: seconds to simulate')
    s.add_argument('--start', type=number(float, 0.0), default=0.0,
                   help='raw mode: time of the first step, s (default 0)')


def _add_simulate_fcd(s: argparse.ArgumentParser) -> None:
    """Add ``simulate``'s options for FCD output and for Parquet parts on Dask."""
    s.add_argument('--digits', type=number(int, 0, 15), default=None,
                   help='FCD XML output: digits after the decimal point of the noisy '
                        'positions (default 8 for lon/lat, about 1 mm, 3 for metres; '
                        'Parquet keeps every digit)')
    s.add_argument('--errors', action='store_true',
                   help='FCD output (XML or Parquet): also write each position\'s error, '
                        'error_north and error_east (m, every digit)')
    s.add_argument('--workers', type=number(int, 1), default=None,
                   help='Parquet parts (--trajectories DIR): a local Dask cluster of N '
                        'processes (default: one per core; needs the extra "dask")')
    s.add_argument('--scheduler', default=None, metavar='ADDRESS',
                   help='Parquet parts: run them on the Dask cluster whose scheduler is at '
                        'ADDRESS (tcp://host:8786) instead of a local one')


def _add_diagnose(sub: 'Subparsers') -> None:
    d = sub.add_parser(
        'diagnose', help='find what the AR model misses, add it, report',
        description='Split INPUT in time (first 70 % trains, the rest is '
                    'held out), fit the paper\'s AR model on the training '
                    'part, test its innovations (serial and cross-axis '
                    'correlation, tails, persistence of the squares, '
                    'dependence on the motion of the truth, a covariance '
                    'that turns with the direction of travel, a cycle, '
                    'jumps that come back; Holm, the whole diagnosis at 5 %), '
                    'attribute the structure to cross_axis_coupling, '
                    'motion_lag, heavy_tails, variance_regimes, street_frame, '
                    'periodic or outliers (or report '
                    'it as unexplained), keep the subset of those effects '
                    'that simulates best by blocked cross-validation over '
                    'the training part (NLL, with a veto on the CRPS of '
                    'simulated measures), fit the '
                    'extended model with it and report the error before '
                    'and after on the held-out part. See '
                    'docs/close-the-loop.md.')
    d.add_argument('input', nargs='+',
                   help='trace CSV or rosbag2 directory; several, or a folder of them, '
                        'are recordings of one receiver (each keeps its own segments)')
    _add_input_options(d)
    d.add_argument('--json', dest='json_out', help='write the findings as JSON')
    d.add_argument('--report', help='directory for the figures (PNG)')
    d.add_argument('--profile-out', help='write the extended model as a profile '
                                         'YAML (with an effects section)')
    d.add_argument('--population', action='store_true',
                   help='with --profile-out: write the population profile instead, the '
                        'extended model fitted within blocks of 300 s of the training part '
                        'and a population section (each agent its own bias and scale), the '
                        'class that holds best on recordings left out (docs/generalisation.md); '
                        'with fewer than 3 blocks, no spread to fit: the extended profile')
    d.add_argument('--sims', type=number(int, MIN_SIMS), default=100,
                   help='simulated traces for the fidelity measures (default 100)')
    d.add_argument('--seed', type=number(int, 0, 2 ** 32 - 1), default=0,
                   help='seed of the simulations and the bootstrap')


def _add_compare(sub: 'Subparsers') -> None:
    c = sub.add_parser(
        'compare', help='every model class as a simulator of the held-out data',
        description='The split and models of diagnose, and the model classes '
                    'simulators use (white noise + bias, AR(1), ARMA(1,1), the '
                    'paper\'s AR(3), AR(p) and the extended model): for each, '
                    'the held-out NLL (and its difference from the lowest '
                    'class\'s, paired on the same samples, with a 95 % '
                    'block-bootstrap interval) and, from SIMS traces simulated on the '
                    'held-out truth and time grid, every fidelity measure '
                    '(autocorrelation at lags 1-30 per axis, north-east '
                    'correlation, SD per axis, horizontal quantiles 50/68/95/99 '
                    '%; outages, steps in outages, median and longest outage '
                    'where the held-out part '
                    'or the training part has outages, the extended class '
                    'with availability fitted on the training gaps) with the '
                    'simulated median, central 95 % range and the '
                    'measured value\'s percentile; inside_95 is the share of '
                    'measures inside their range (near 0.95 when calibrated).')
    c.add_argument('input', nargs='+',
                   help='trace CSV or rosbag2 directory; several, or a folder of them, '
                        'are recordings of one receiver (each keeps its own segments)')
    _add_input_options(c)
    c.add_argument('--json', dest='json_out', help='write the comparison as JSON')
    c.add_argument('--zones', default=None,
                   help='zone map (GeoJSON): also compare one profile against a profile '
                        'per zone (zones with >= 300 training samples), held-out NLL and '
                        'inside_95, and the NLL per zone (needs shapely)')
    c.add_argument('--report', help='directory for the figure (compare.png)')
    c.add_argument('--sims', type=number(int, MIN_SIMS), default=100,
                   help='simulated traces per class (default 100)')
    c.add_argument('--seed', type=number(int, 0, 2 ** 32 - 1), default=0,
                   help='seed of the simulations')
    c.add_argument('--folds', choices=('rolling', 'recordings'), default=None,
                   help='judge on several splits, with the population class too, '
                        'each class\'s NLL against the population class\'s (the folds '
                        'where it is lower or higher beyond its 95 %% interval, and '
                        'where a lower one gains: far from the population\'s bias or '
                        'not, the lags of partial autocorrelation only the training '
                        'part has) and '
                        'the measures in groups (persistence, scale, bias, quantiles, '
                        'tails, a Kalman filter\'s and a V2P warning\'s results, '
                        'outages where a part has them; speed and course by speed band '
                        'where the trace has them): '
                        'rolling: train before each of 3 origins (50, 62.5, 75 %% of '
                        'the span), hold out the next 12.5 %%; recordings: hold out each '
                        'INPUT recording in turn, train on the others (JSON only)')
    c.add_argument('--test', nargs='+', default=None, metavar='TEST',
                   help='hold out these recordings (files or folders) and train on the '
                        'INPUTs: another day, another stretch (judged as --folds)')
    c.add_argument('--smoother', type=number(int, 0, 10000), default=0, metavar='N',
                   help='with --folds or --test: also feed GTSAM\'s iSAM2 (GPS and '
                        'odometry factors) the real fixes and N simulated traces of each '
                        'class, on the first 600 held-out samples: the group smoother '
                        '(online and smoothed error; needs gtsam: pip install '
                        '"gps_error_ros[smoother]"; default 0: off)')


def _add_import(sub: 'Subparsers') -> None:
    m = sub.add_parser(
        'import', help='turn a recording and its truth into a trace CSV',
        description='Read a recording in a format phones and receivers write '
                    '(nmea: NMEA 0183 GGA + RMC, checksums checked, talker IDs '
                    'GP/GN/GL/...; needs pynmea2: pip install '
                    '"gps_error_ros[import]"; gnsslogger: an Android GnssLogger '
                    'log\'s Fix records, either layout, by its own header; gpx: '
                    'track points, needs gpxpy) and pair it with its truth: a '
                    'reference receiver\'s NMEA or a GPX track (*.gpx), '
                    'interpolated linearly in time to the fixes\' stamps, or a '
                    'fixed point LAT,LON[,ALT] for a '
                    'static receiver. Writes the trace CSV that calibrate, '
                    'validate, diagnose and compare read, with alt and truth_alt, '
                    'and, where the recording has them, speed, bearing, hdop, '
                    'accuracy, truth_speed and truth_bearing.')
    m.add_argument('format', choices=('nmea', 'gnsslogger', 'gpx'),
                   help='the recording\'s format')
    m.add_argument('input', help='the recording (e.g. the phone\'s NMEA log)')
    m.add_argument('--truth',
                   help='truth: a reference receiver\'s NMEA file, a GPX track '
                        '(*.gpx), or LAT,LON[,ALT]')
    m.add_argument('--landmarks',
                   help='truth by the paper\'s method: a CSV of landmarks (name, '
                        'lat, lon[, alt]); with --passes')
    m.add_argument('--passes',
                   help='a CSV of the times the landmarks were passed (time: UTC '
                        's or ISO 8601, landmark); constant speed in between')
    m.add_argument('-o', '--output', required=True, help='trace CSV to write')
    m.add_argument('--truth-date', type=_date, default=None,
                   help='UTC date (YYYY-MM-DD) of an NMEA truth whose RMC sentences '
                        'give none (default: the first fix\'s date)')
    m.add_argument('--provider', default='gps',
                   help='gnsslogger: the Fix provider to keep (default gps)')
    m.add_argument('--max-truth-gap', type=number(float, 0.0, lo_open=True), default=None,
                   help='longest truth interval (s) bridged by interpolation '
                        '(default 3 x the median, >= 1.5 s)')


def _add_synth(sub: 'Subparsers') -> None:
    y = sub.add_parser(
        'synth', help='write a synthetic walk with an undeclared effect',
        description='A pedestrian walking Manhattan\'s grid at 1 Hz (turns, '
                    'waits) with phone errors carrying one effect, made by a '
                    'mechanism other than the ones diagnose fits, as a trace '
                    'CSV. Scenarios: ' + ', '.join(_scenarios()) + '.')
    y.add_argument('scenario', choices=_scenarios(), metavar='SCENARIO',
                   help='one of the scenarios listed above')
    y.add_argument('-o', '--output', required=True, help='trace CSV to write')
    y.add_argument('--seed', type=number(int, 0, 2 ** 32 - 1), default=0,
                   help='seed (default 0)')
    y.add_argument('--duration', type=number(int, 60), default=3600,
                   help='seconds (default 3600)')


def _add_scenario(sub: 'Subparsers') -> None:
    c = sub.add_parser(
        'scenario', help='build a georeferenced SUMO walking scenario',
        description='Write a SUMO scenario of people walking a street grid, placed on '
                    'the Earth: netgenerate\'s grid (sidewalks, crossings) with a UTM '
                    'projection in its <location>, randomTrips.py --pedestrians, and '
                    'DIR/grid.sumocfg. With --fcd S, also run SUMO for S seconds with '
                    '--fcd-output.geo into DIR/fcd.xml (lon/lat: gps_error simulate '
                    '--trajectories DIR/fcd.xml reads it as it is). Needs the extra '
                    '"sumo" (eclipse-sumo, whose SUMO_HOME holds randomTrips.py).')
    c.add_argument('out', help='directory to write the scenario into')
    c.add_argument('--lat', type=number(float, -80.0, 84.0), default=40.75,
                   help='latitude of the grid\'s first junction (default 40.75)')
    c.add_argument('--lon', type=number(float, -180.0, 180.0), default=-73.99,
                   help='longitude of the grid\'s first junction (default -73.99)')
    c.add_argument('--grid', type=number(int, 2, 30), default=3,
                   help='junctions per side (default 3)')
    c.add_argument('--length', type=number(float, 10.0, 2000.0), default=80.0,
                   help='metres between junctions (default 80)')
    c.add_argument('--until', type=number(float, 1.0), default=30.0,
                   help='last departure, s (default 30)')
    c.add_argument('--period', type=number(float, 0.01, lo_open=False), default=2.0,
                   help='seconds between departures (default 2)')
    c.add_argument('--seed', type=number(int, 0), default=7, help='seed (default 7)')
    c.add_argument('--fcd', type=number(float, 1.0), default=None, metavar='S',
                   help='run SUMO for S simulated seconds, writing DIR/fcd.xml in lon/lat')


def build_parser() -> argparse.ArgumentParser:
    """Return the ``gps_error`` parser (its subcommands by name: :func:`command_parsers`)."""
    return _build()[0]


def command_parsers() -> tuple[argparse.ArgumentParser, dict[str, argparse.ArgumentParser]]:
    """Return (the ``gps_error`` parser, {subcommand: its parser}) in the order of ``--help``."""
    p, sub = _build()
    return p, dict(sub.choices)


def _build() -> tuple[argparse.ArgumentParser, 'Subparsers']:
    p = argparse.ArgumentParser(
        prog='gps_error',
        description='Smartphone GPS error model tools (no ROS needed).')
    sub = p.add_subparsers(dest='command', required=True, metavar='COMMAND')
    for add in (_add_calibrate, _add_validate, _add_simulate, _add_diagnose,
                _add_compare, _add_import, _add_synth, _add_scenario):
        add(sub)
    from gps_error_ros.cli.tables import add_split
    add_split(sub, number)
    return p, sub
