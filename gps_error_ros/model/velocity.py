"""
Reported speed and course: a phone's Doppler velocity, with its error.

A profile's optional ``velocity`` section::

    velocity:
      sigma: 0.2        # m/s: SD of each east/north component of the velocity error
      phi: 0.75         # the error's lag-1 autocorrelation (per model step)
      lag_s: 0.3        # the reported velocity is the truth's this much earlier
      standstill: 0.0   # m/s: at or below this true speed the phone reports 0, no course

The phone's velocity is the truth's ``lag_s`` earlier plus a two-dimensional
error ``w`` (east, north), a stationary AR(1) per component:
``w_k = phi w_{k-1} + sqrt(1 - phi^2) sigma z_k``, with ``z`` from the
agent's stream (domain ``velocity``; the start from ``init_velocity``). The
reported speed is ``|v|`` (never negative) and the course its direction
(degrees clockwise from north). So the course error grows as the speed
falls (about ``sigma / speed`` radians), as Doppler courses do. At or
below ``standstill`` true speed the phone reports speed 0 and no course:
both measured phones did so at 94-99 % of the rows where the reference
stood still (the fitted value is 0: they did it only at a true
standstill). The velocity error is independent of the position error (the
two come from different observables: Doppler against pseudoranges).
"""

from dataclasses import dataclass

import numpy as np

from gps_error_ros.model import streams

_KEYS = ('lag_s', 'phi', 'sigma', 'standstill')


class VelocityError(ValueError):
    """A ``velocity`` section that is not valid."""


@dataclass(frozen=True)
class Velocity:
    """Velocity error parameters (see module doc)."""

    sigma: float
    phi: float
    lag_s: float
    standstill: float

    def to_dict(self):
        """Return the profile section as plain data."""
        return {k: float(getattr(self, k)) for k in ('sigma', 'phi', 'lag_s', 'standstill')}

    def initial(self, keys, index):
        """Return the error (n, 2) east/north at a run's first step ``index``."""
        return self.sigma * streams.normal_pairs(keys, streams.DOMAIN_INIT_VELOCITY, index)

    def step(self, w, keys, index):
        """Return the error at step ``index`` after ``w`` at the step before."""
        z = streams.normal_pairs(keys, streams.DOMAIN_VELOCITY, index)
        return self.phi * w + np.sqrt(1.0 - self.phi ** 2) * self.sigma * z

    def errors(self, keys, n_steps, start=0):
        """Return the velocity errors at steps ``start ..``, (n_steps, n, 2) east/north m/s."""
        return series(self, keys, n_steps, start)

    def report(self, v_true, w):
        """
        Return (speed m/s, course deg) a phone reports for true velocity ``v_true``.

        ``v_true`` and ``w`` are (..., 2) east/north, the truth already taken
        ``lag_s`` earlier. At or below ``standstill`` the speed is 0 and the course NaN.
        """
        v_true = np.asarray(v_true, dtype=float)
        v = v_true + w
        speed = np.hypot(v[..., 0], v[..., 1])
        course = course_deg(v)
        still = np.hypot(v_true[..., 0], v_true[..., 1]) <= self.standstill   # NaN: not still
        speed = np.where(still, 0.0, speed)
        course = np.where(still, np.nan, course)
        return speed, course


def series(process, keys, n_steps, start=0):
    """
    Return a side stream's values at steps ``start ..``, (n_steps, n, d).

    ``process`` has ``initial(keys, index)`` and ``step(w, keys, index)``
    (the velocity error; the stated accuracy's fluctuation, :mod:`reported`).
    """
    keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
    first = process.initial(keys, start)
    out = np.empty((n_steps,) + first.shape)
    if not n_steps:
        return out
    out[0] = w = first
    for i in range(1, n_steps):
        out[i] = w = process.step(w, keys, start + i)
    return out


def course_deg(v):
    """Return the direction of east/north velocities (..., 2), degrees clockwise from north."""
    return np.degrees(np.arctan2(v[..., 0], v[..., 1])) % 360.0


def velocity_from_dict(raw, source='<profile>'):
    """Validate a ``velocity`` mapping; return :class:`Velocity`."""
    if not isinstance(raw, dict) or sorted(raw) != sorted(_KEYS):
        raise VelocityError(f'{source}: key \'velocity\': expected a mapping with exactly '
                            f'{list(_KEYS)}, got {raw!r}')
    bounds = {'sigma': (0.0, 100.0, True), 'phi': (-1.0, 1.0, True),
              'lag_s': (0.0, 10.0, False), 'standstill': (0.0, 100.0, False)}
    vals = {}
    for k, (lo, hi, open_ends) in bounds.items():
        v = raw[k]
        ok = isinstance(v, (int, float)) and not isinstance(v, bool) and (
            lo < v < hi if open_ends else lo <= v <= hi)
        if not ok:
            ends = '()' if open_ends else '[]'
            raise VelocityError(f'{source}: key velocity.{k}: expected a number in '
                                f'{ends[0]}{lo:g}, {hi:g}{ends[1]}, got {v!r}')
        vals[k] = float(v)
    return Velocity(**vals)
