"""
One crossing of two streets, with pedestrians who cross them and vehicles that drive through.

The true motion of the pedestrian-to-vehicle study
(:mod:`~gps_error_ros.ns3.p2v`), as waypoints: piecewise-straight tracks
that ns-3's ``WaypointMobilityModel`` follows, and that the study's truth
(:meth:`~gps_error_ros.ns3.tracks.Tracks.at`) interpolates the same way.

Two streets cross at the origin: one east-west along x, one north-south
along y, each with a lane each way (``lane`` metres from the centre
line; vehicles keep right). Sidewalks run
``sidewalk`` metres from each centre line; the four corners where they
meet are joined by crosswalks across the streets. A pedestrian walks along
a sidewalk to a corner, waits at the kerb, crosses to the next corner (and
sometimes on across the other street), then walks away. A vehicle drives
straight through the crossing at a steady speed. Nobody yields: a
pedestrian in a vehicle's lane is a conflict the warning should catch.
"""

from dataclasses import dataclass

import numpy as np

from gps_error_ros.model.state import FloatArray
from gps_error_ros.ns3.tracks import Tracks


@dataclass(frozen=True)
class Crossing:
    """The crossing's layout, in metres from its centre."""

    lane: float = 1.75
    sidewalk: float = 8.0
    #: how far from the centre vehicles appear and leave
    arm: float = 250.0


def _corners(c: Crossing) -> FloatArray:
    """Return the four sidewalk corners, counter-clockwise from the north-east."""
    s = c.sidewalk
    return np.array([[s, s], [-s, s], [-s, -s], [s, -s]])


def pedestrians(n: int, duration: float, rng: np.random.Generator,
                c: Crossing = Crossing()) -> Tracks:
    """
    Return ``n`` pedestrians' tracks over ``duration`` seconds.

    Each starts on a sidewalk up to most of a walk's length from a corner,
    walks to it at 1.1-1.6 m/s, waits 0-8 s at the kerb, crosses to a
    neighbouring corner, crosses on across the other street half the time,
    and walks away.
    """
    corners = _corners(c)
    times, points = [], []
    for _ in range(n):
        speed = rng.uniform(1.1, 1.6)
        k = int(rng.integers(4))
        out = np.sign(corners[k]) * (np.eye(2)[rng.integers(2)])    # a sidewalk leaving k
        walk_in = 2.0 + rng.uniform(0.0, max(0.6 * speed * duration - 2.0, 0.0))
        path = [corners[k] + out * walk_in, corners[k]]
        turn = 1 if rng.random() < 0.5 else -1
        waits = [0.0, rng.uniform(0.0, 8.0)]
        for _ in range(1 + int(rng.random() < 0.5)):
            k = (k + turn) % 4
            path.append(corners[k])
            waits.append(rng.uniform(0.0, 8.0))
        away = np.sign(corners[k]) * np.eye(2)[rng.integers(2)]
        path.append(corners[k] + away * speed * duration)
        waits[-1] = 0.0
        t, pts = [0.0], [path[0]]
        for p, w in zip(path[1:], waits[1:] + [0.0]):
            t.append(t[-1] + float(np.hypot(*(p - pts[-1]))) / speed)
            pts.append(p)
            if w > 0:
                t.append(t[-1] + w)
                pts.append(p)
        times.append(np.array(t))
        points.append(np.array(pts, dtype=float))
    return Tracks([f'ped{i}' for i in range(n)], times, points)


def vehicles(n: int, duration: float, rng: np.random.Generator,
             c: Crossing = Crossing()) -> Tracks:
    """
    Return ``n`` vehicles' tracks: each drives straight through at 8-14 m/s.

    They come in turn from the four arms, in their right-hand lane, and
    reach the centre at times spread over the run. Before it enters a
    vehicle waits where it will appear; after it leaves, where it left.
    """
    heads = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    times, points = [], []
    centre_times = np.sort(rng.uniform(0.1, 0.9, n)) * duration
    for i in range(n):
        u = heads[i % 4]
        right = np.array([u[1], -u[0]])
        speed = rng.uniform(8.0, 14.0)
        enter = centre_times[i] - c.arm / speed
        start = right * c.lane - u * c.arm
        end = right * c.lane + u * c.arm
        leave = enter + 2 * c.arm / speed
        if enter > 0:
            t = [0.0, enter, leave]
            pts = [start, start, end]
        else:
            t = [0.0, leave]
            pts = [start + u * speed * -enter, end]
        times.append(np.array(t))
        points.append(np.array(pts, dtype=float))
    return Tracks([f'veh{i}' for i in range(n)], times, points)
