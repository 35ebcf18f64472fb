"""
A simulated pedestrian walking Manhattan's avenues, for demos and tests.

The walk is a random route on an idealised Manhattan grid: avenues run along
the grid's "uptown" bearing (29 degrees east of true north), streets cross
them at right angles. Blocks along an avenue are 80 m (street to street),
blocks along a street 260 m (avenue to avenue). At every corner the walker
goes straight on or turns, and waits for the light at crossings. Positions
are east/north metres in a local frame whose origin is the corner of 7th
Avenue and West 34th Street.
"""

from dataclasses import dataclass

import numpy as np

from gps_error_ros.model.state import FloatArray, Numbers

#: WGS84 latitude, longitude, ellipsoidal height (m) of the frame origin:
#: 7th Avenue & W 34th St, Manhattan (height ~ 10 m above the geoid there,
#: about -33 m geoid undulation).
MANHATTAN_DATUM = (40.75057, -73.99065, -23.0)

GRID_BEARING_DEG = 29.0
AVENUE_BLOCK_M = 80.0
STREET_BLOCK_M = 260.0


@dataclass(frozen=True)
class Walk:
    """
    A piecewise-linear walk: positions at the breakpoint times.

    Attributes
    ----------
    t : numpy.ndarray
        Breakpoint times (s), increasing.
    east, north : numpy.ndarray
        Positions (m) at those times; between them the walker moves in a
        straight line at constant speed (or stands, when equal).

    """

    t: np.ndarray
    east: np.ndarray
    north: np.ndarray

    @property
    def duration(self) -> float:
        """Return the walk's length in seconds."""
        return float(self.t[-1] - self.t[0])

    def position(self, t: Numbers) -> tuple[FloatArray, FloatArray]:
        """Return (east, north) at times ``t`` (array or float)."""
        return (np.interp(t, self.t, self.east), np.interp(t, self.t, self.north))

    def speed(self, t: Numbers) -> FloatArray:
        """Return the walking speed in m/s at times ``t``."""
        seg = np.clip(np.searchsorted(self.t, t, side='right') - 1, 0,
                      len(self.t) - 2)
        dt = self.t[seg + 1] - self.t[seg]
        dist = np.hypot(self.east[seg + 1] - self.east[seg],
                        self.north[seg + 1] - self.north[seg])
        return np.divide(dist, dt, out=np.zeros_like(dist), where=dt > 0)


def _next_heading(ave: int, st: int, heading: tuple[int, int], rng: np.random.Generator,
                  avenues: tuple[int, int], streets: tuple[int, int],
                  turn_probability: float) -> tuple[int, int]:
    """Return the heading at corner (ave, st): straight on, or a turn."""
    options = []
    for h in ((0, 1), (0, -1), (1, 0), (-1, 0)):
        if h == (-heading[0], -heading[1]):
            continue
        a2, s2 = ave + h[0], st + h[1]
        if avenues[0] <= a2 <= avenues[1] and streets[0] <= s2 <= streets[1]:
            options.append(h)
    if not options:
        options = [(-heading[0], -heading[1])]
    if heading in options and (len(options) == 1
                               or rng.random() > turn_probability):
        return heading
    turns = [h for h in options if h != heading] or options
    return turns[rng.integers(len(turns))]


def manhattan_walk(duration: float, rng: np.random.Generator, speed: float = 1.4,
                   avenues: tuple[int, int] = (0, 3), streets: tuple[int, int] = (-4, 16),
                   turn_probability: float = 0.25, red_probability: float = 0.5,
                   red_wait: tuple[float, float] = (5.0, 45.0)) -> Walk:
    """
    Return a random :class:`Walk` of at least ``duration`` seconds.

    Parameters
    ----------
    duration
        Seconds of walk wanted.
    rng
        The walk's randomness (route, speeds, waits).
    speed
        Mean walking speed (m/s); each block's speed varies by +-15 %.
    avenues
        Grid bounds, in avenues west of 7th.
    streets
        Grid bounds, in streets north of 34th.
    turn_probability
        Chance of turning at a corner (where the grid allows going straight).
    red_probability
        Chance of waiting at a corner for the light.
    red_wait
        Uniform range of a wait (s).

    Returns
    -------
    Walk
        The route, its timing and its waits.

    """
    if not duration > 0:
        raise ValueError(f'duration must be > 0, got {duration}')
    bearing = np.radians(GRID_BEARING_DEG)
    uptown = np.array([np.sin(bearing), np.cos(bearing)])     # (east, north)
    west = np.array([-np.cos(bearing), np.sin(bearing)])
    # Position on the grid: (avenue index, street index); heading as a step.
    ave, st = 0, 0
    heading = (0, 1)
    t, pts, times = 0.0, [(0.0, 0.0)], [0.0]

    def xy(a: float, s: float) -> tuple[float, float]:
        p = a * STREET_BLOCK_M * west + s * AVENUE_BLOCK_M * uptown
        return float(p[0]), float(p[1])

    while t < duration:
        heading = _next_heading(ave, st, heading, rng, avenues, streets,
                                turn_probability)
        ave, st = ave + heading[0], st + heading[1]
        block = STREET_BLOCK_M if heading[1] == 0 else AVENUE_BLOCK_M
        v = speed * rng.uniform(0.85, 1.15)
        t += block / v
        pts.append(xy(ave, st))
        times.append(t)
        if rng.random() < red_probability:
            t += rng.uniform(*red_wait)
            pts.append(pts[-1])
            times.append(t)
    xy_m = np.array(pts)
    return Walk(np.array(times), xy_m[:, 0], xy_m[:, 1])
