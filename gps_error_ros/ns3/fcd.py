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
from gps_error_ros.sim.fcd_step import xml_position_mode
from gps_error_ros.traces.trajectories import iter_fcd, TrajectoryError


def fcd_tracks(path: PathArg, coordinates: str | None = None, net: PathArg | None = None,
               datum: tuple[float, float] = MANHATTAN) -> tuple[Tracks, float]:
    """
    Return every agent's track of an FCD XML file, and the file's first time with an agent.

    ``coordinates`` and ``net``: what the file's x/y are, as ``simulate``'s
    ``--coordinates`` and ``--net``, read the same way (SUMO's options
    comment at the top says it when present). Positions on the globe
    (lon/lat, or a georeferenced network's metres) become metres east and
    north of ``datum``; a network without a projection keeps its own x/y.
    """
    mode, proj = xml_position_mode(path, net, coordinates)
    rows: dict[str, list[tuple[float, float, float]]] = {}
    for t, _, agents in iter_fcd(Path(path)):
        for name, x, y, _ in agents:
            rows.setdefault(name, []).append((t, x, y))
    if not rows:
        raise TrajectoryError(f'{path}: no person or vehicle in any timestep: expected '
                              f'positions to follow')
    frame = LocalTangentFrame(*datum)
    names = list(rows)
    times, points = [], []
    for n in names:
        t, x, y = np.asarray(rows[n], dtype=float).T
        if mode == 'net':
            assert proj is not None
            x, y = proj.to_lonlat(x, y)
        if mode != 'plane':
            x, y, _ = frame.to_enu(np.asarray(y, dtype=float), np.asarray(x, dtype=float))
        times.append(t)
        points.append(np.column_stack([x, y]))
    first = min(float(t[0]) for t in times)
    return Tracks(names, times, points), first
