"""``gps_error calibrate --zones``: a profile per zone of a map."""

import argparse
from collections.abc import Callable
from pathlib import Path

from gps_error_ros.traces.trace_io import Trace


def calibrate_per_zone(args: argparse.Namespace,
                       load_input: Callable[[argparse.Namespace], Trace]) -> int:
    """
    Run ``gps_error calibrate --zones``: a profile per zone; return the exit code.

    ``load_input(args)`` reads the recording (after the options are checked).
    """
    from gps_error_ros.fit.zone_calibration import (calibrate_zones, MIN_ZONE_SAMPLES,
                                                    write_zone_profiles)
    from gps_error_ros.model.zones import load_zone_map

    if args.population:
        raise ValueError('--population with --zones: not fitted: the zone profiles are '
                         'fitted on each zone\'s errors as they are; fit the receiver\'s '
                         'population on the whole recording (calibrate --population) and '
                         'name that profile as the map\'s default_profile')
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise ValueError(f'-o {out}: with --zones, expected a directory for the '
                         f'profiles and the zone map, got an existing file')
    zone_map = load_zone_map(args.zones)
    trace = load_input(args)
    whole, fits = calibrate_zones(trace, zone_map, args.order, args.max_order)
    dst = write_zone_profiles(out, trace.name, args.zones, zone_map, whole, fits)
    print(f'{trace.name}: {whole.grid.n} samples; zones need {MIN_ZONE_SAMPLES} '
          f'samples for a profile of their own')
    for fit in fits:
        if fit.fits is None:
            print(f'  {fit.name}: fallback all.yaml ({fit.reason})')
            continue
        orders = '/'.join(str(f.params.order) for f in fit.fits)
        print(f'  {fit.name}: {fit.samples} samples in {fit.segments} segment(s), '
              f'AR orders north/east {orders}')
    print(f'wrote {dst} and the profiles beside it')
    return 0
