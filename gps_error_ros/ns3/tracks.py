"""
Agents' true tracks as waypoints, and ns-3 nodes that follow them.

A :class:`Tracks` is each agent's piecewise-straight track: the times and
x/y metres where its direction or speed changes. ns-3's
``WaypointMobilityModel`` follows it between waypoints as
:meth:`Tracks.at` interpolates it, so the truth a study scores against is
the position ns-3's radio had. Before its first waypoint a node stands at
it, and after its last at that one.
"""

from dataclasses import dataclass
from typing import Any

import numpy as np

from gps_error_ros.model.state import FloatArray


@dataclass
class Tracks:
    """Agents' waypoints: ``times[i]`` (s, increasing) and ``points[i]`` (x/y metres)."""

    names: list[str]
    times: list[FloatArray]
    points: list[FloatArray]

    def at(self, t: FloatArray) -> FloatArray:
        """Return every agent's position at times ``t``: an array (agents, times, 2)."""
        t = np.asarray(t, dtype=float)
        out = np.empty((len(self.names), t.size, 2))
        for i in range(len(self.names)):
            out[i] = self.of(i, t)
        return out

    def of(self, i: int, t: FloatArray) -> FloatArray:
        """Return agent ``i``'s positions at times ``t``: an array (times, 2)."""
        t = np.asarray(t, dtype=float)
        tt, pp = self.times[i], self.points[i]
        return np.column_stack([np.interp(t, tt, pp[:, 0]), np.interp(t, tt, pp[:, 1])])

    def velocity(self, t: FloatArray) -> FloatArray:
        """Return every agent's velocity at times ``t``, in m/s: an array (agents, times, 2)."""
        t = np.asarray(t, dtype=float)
        out = np.zeros((len(self.names), t.size, 2))
        for i, (tt, pp) in enumerate(zip(self.times, self.points)):
            seg = np.clip(np.searchsorted(tt, t, side='right') - 1, 0, len(tt) - 2)
            dt = tt[seg + 1] - tt[seg]
            inside = (t >= tt[0]) & (t < tt[-1]) & (dt > 0)
            v = (pp[seg + 1] - pp[seg]) / np.where(dt > 0, dt, 1.0)[:, None]
            out[i][inside] = v[inside]
        return out


def waypoint_nodes(tracks: Tracks) -> Any:
    """Return a new ns-3 node per agent of ``tracks``, following it (``WaypointMobilityModel``)."""
    from ns import ns
    nodes = ns.NodeContainer()
    nodes.Create(len(tracks.names))
    helper = ns.MobilityHelper()
    helper.SetMobilityModel('ns3::WaypointMobilityModel')
    helper.Install(nodes)
    for i, (tt, pp) in enumerate(zip(tracks.times, tracks.points)):
        m = nodes.Get(i).GetObject[ns.WaypointMobilityModel]()
        for t, (x, y) in zip(tt.tolist(), pp.tolist()):
            m.AddWaypoint(ns.Waypoint(ns.Seconds(t), ns.Vector(x, y, 0.0)))
    return nodes
