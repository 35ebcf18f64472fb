"""
SUMO's FCD as ns-3 nodes: one node per person or vehicle, following its positions.

:func:`fcd_tracks` reads an FCD XML file (``sumo --fcd-output``) into
:class:`~gps_error_ros.ns3.tracks.Tracks` in the x/y metres of an ns-3
scenario about a datum; :func:`~gps_error_ros.ns3.tracks.waypoint_nodes`
makes the nodes. With :class:`~gps_error_ros.ns3.source.GpsSource` given the
agents' names, the same datum and ``start=first``, a node gets the errors
``gps_error simulate`` gives that agent on the same file. A node exists for
the whole run: before its agent appears it stands where it will appear, and
after it leaves, where it left.
"""

from pathlib import Path

import numpy as np

from gps_error_ros.model.atomic import PathArg
from gps_error_ros.model.geodesy import LocalTangentFrame
from gps_error_ros.ns3.source import MANHATTAN
from gps_error_ros.ns3.tracks import Tracks
from gps_error_ros.sim.fcd_step import position_mode
from gps_error_ros.traces.trajectories import (check_fcd_root, fcd_coordinates, fcd_net_file,
                                               iter_fcd, TrajectoryError)


def fcd_tracks(path: PathArg, coordinates: str | None = None, net: PathArg | None = None,
               datum: tuple[float, float] = MANHATTAN) -> tuple[Tracks, float]:
    """
    Return every agent's track of an FCD XML file, and the file's first time with an agent.

    ``coordinates`` and ``net``: what the file's x/y are, as ``simulate``'s
    ``--coordinates`` and ``--net`` (SUMO's options comment at the top says
    it when present). Positions on the globe (lon/lat, or a georeferenced
    network's metres) become metres east and north of ``datum``; a
    network without a projection keeps its own x/y.
    """
    check_fcd_root(path)
    said = coordinates or fcd_coordinates(path)
    if said is None:
        raise TrajectoryError(f'{path}: no SUMO options comment at the top, so whether x/y '
                              f'are lon/lat or metres is unknown: pass coordinates='
                              f'"lonlat" or "xy"')
    if net is None and said == 'lonlat':
        net = fcd_net_file(path)
    mode, proj = position_mode(path, said, net)
    times: dict[str, list[float]] = {}
    xs: dict[str, list[float]] = {}
    ys: dict[str, list[float]] = {}
    for t, _, agents in iter_fcd(Path(path)):
        for name, x, y, _ in agents:
            times.setdefault(name, []).append(t)
            xs.setdefault(name, []).append(x)
            ys.setdefault(name, []).append(y)
    if not times:
        raise TrajectoryError(f'{path}: no person or vehicle in any timestep: expected '
                              f'positions to follow')
    frame = LocalTangentFrame(*datum)
    names = list(times)
    points = []
    for n in names:
        x, y = np.asarray(xs[n], dtype=float), np.asarray(ys[n], dtype=float)
        if mode == 'net':
            assert proj is not None
            x, y = proj.to_lonlat(x, y)
        if mode != 'plane':
            x, y, _ = frame.to_enu(np.asarray(y, dtype=float), np.asarray(x, dtype=float))
        points.append(np.column_stack([x, y]))
    first = min(v[0] for v in times.values())
    return Tracks(names, [np.asarray(times[n]) for n in names], points), first
