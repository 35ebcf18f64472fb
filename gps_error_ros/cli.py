"""
``gps_error``: the command-line tools that need no ROS.

``gps_error calibrate INPUT -o PROFILE.yaml`` fits a profile from a trace CSV.
"""

import argparse
from pathlib import Path
import sys

from .calibration import calibrate, CalibrationError, DEFAULT_MAX_ORDER, \
    write_profile
from .profiles import load_profile_file, ProfileError
from .trace_io import read_trace_csv, TraceError


def _parser():
    p = argparse.ArgumentParser(
        prog='gps_error',
        description='Smartphone GPS error model tools (no ROS needed).')
    sub = p.add_subparsers(dest='command', required=True)
    c = sub.add_parser(
        'calibrate', help='fit a profile from a measured trace',
        description='Fit an AR profile (schema 1, with a fit section) to the '
                    'errors of a measured trace against its ground truth. '
                    'INPUT is a trace CSV (columns t, lat, lon, truth_lat, '
                    'truth_lon; see shared/data/README.md).')
    c.add_argument('input', help='trace CSV')
    c.add_argument('-o', '--output', required=True, help='profile YAML to write')
    c.add_argument('--order', type=int, default=None,
                   help='fix the AR order (default: chosen per axis by the PACF)')
    c.add_argument('--max-order', type=int, default=DEFAULT_MAX_ORDER,
                   help=f'largest order the PACF may choose (default '
                        f'{DEFAULT_MAX_ORDER})')
    c.add_argument('--name', default=None,
                   help='profile name (default: the output file stem)')
    return p


def cmd_calibrate(args):
    """Run ``gps_error calibrate``; return the exit code."""
    path = Path(args.input)
    if path.is_dir() or path.suffix.lower() in ('.mcap', '.db3'):
        print(f'gps_error calibrate: {path}: rosbag2 input is not supported '
              f'yet; expected a trace CSV', file=sys.stderr)
        return 2
    trace = read_trace_csv(path)
    result = calibrate(trace, order=args.order, max_order=args.max_order)
    out = Path(args.output)
    profile = result.profile_dict(args.name or out.stem)
    write_profile(out, profile)
    load_profile_file(out)          # what we write must load as it is
    g = result.grid
    print(f'{trace.name}: {g.n} samples in {len(g.segments)} segment(s), '
          f'{g.span_s:.0f} s')
    for ax, fit in (('north', result.north), ('east', result.east)):
        p = fit.params
        print(f'  {ax}: AR({p.order}) (PACF chose {fit.pacf_order}, BIC '
              f'{fit.bic_order}) delta={p.delta:.4f} '
              f'phi={[round(v, 4) for v in p.phi]} sigma_w={p.sigma_w:.4f}')
    print(f'wrote {out}')
    return 0


def main(argv=None):
    """Entry point of ``gps_error``."""
    args = _parser().parse_args(argv)
    try:
        return {'calibrate': cmd_calibrate}[args.command](args)
    except (TraceError, CalibrationError, ProfileError) as exc:
        print(f'gps_error {args.command}: {exc}', file=sys.stderr)
        return 2


if __name__ == '__main__':
    raise SystemExit(main())
