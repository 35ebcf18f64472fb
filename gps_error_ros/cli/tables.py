"""``gps_error simulate`` on Parquet FCD (one file, or parts on Dask) and ``gps_error split``."""

import argparse
from pathlib import Path
from typing import Any

from gps_error_ros.traces.fcd_parquet import is_parquet


def is_table_input(src: Path) -> bool:
    """Return whether ``--trajectories`` is Parquet: a ``.parquet`` file or a folder of parts."""
    return is_parquet(src) or src.is_dir()


def simulate_table(args: argparse.Namespace, model: Any, profile: Any, bias: Any,
                   faults: list[Any], zones: Any) -> dict[str, int]:
    """Run ``simulate`` on a Parquet file, or on a directory of parts over Dask's workers."""
    from gps_error_ros.sim.fcd_step import FcdRequest
    src = Path(args.trajectories)
    request = FcdRequest(model, profile.rate_hz, args.seed, args.net, args.coordinates, zones,
                         args.covariance_mode, profile.reported_accuracy, profile.velocity,
                         bias, tuple(faults), args.errors)
    if src.is_dir():
        from gps_error_ros.sim.parquet_parts import simulate_parts
        if Path(args.out).suffix:
            raise ValueError(f'--out {args.out}: the parts of {src} go to a directory of '
                             f'parts of the same names: expected a directory name')
        return simulate_parts(src, args.out, request, scheduler=args.scheduler,
                              workers=args.workers)
    if args.scheduler or args.workers:
        raise ValueError('--scheduler and --workers run the parts of a directory (gps_error '
                         'split writes them): give --trajectories DIR')
    if not is_parquet(args.out):
        raise ValueError(f'--out {args.out}: Parquet in, Parquet out: expected a .parquet name')
    from gps_error_ros.sim.simulate_parquet import simulate_parquet
    return simulate_parquet(src, args.out, request)


def cmd_split(args: argparse.Namespace) -> int:
    """Run ``gps_error split``; return the exit code."""
    from gps_error_ros.sim.parquet_parts import split_by_agent
    paths = split_by_agent(args.trajectories, args.out, args.parts)
    print(f'wrote {len(paths)} parts to {args.out}: gps_error simulate --trajectories '
          f'{args.out} --out OUT_DIR [--scheduler ADDRESS | --workers N]')
    return 0


def add_split(sub: Any, number: Any) -> None:
    """Add the ``split`` command to the parser's subcommands."""
    s = sub.add_parser(
        'split', help='split a Parquet FCD file by agent into parts for workers',
        description='Split SUMO\'s FCD as Parquet by agent (a stable hash of its id) into '
                    'DIR/part-000.parquet ...: each part keeps its agents\' rows in time '
                    'order and every column. gps_error simulate --trajectories DIR runs the '
                    'parts on Dask\'s workers with the errors of the whole file. Needs the '
                    'extra "parquet".')
    s.add_argument('--trajectories', required=True, help='SUMO FCD .parquet')
    s.add_argument('--parts', type=number(int, 1), required=True, help='number of parts')
    s.add_argument('--out', required=True, help='directory to write the parts into')
