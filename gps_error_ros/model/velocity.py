"""
Reported speed and course: a phone's Doppler velocity, with its error.

A profile's optional ``velocity`` section::

    velocity:
      sigma: 0.2        # m/s: SD of each east/north component of the velocity error
      phi: 0.75         # the error's lag-1 autocorrelation (per model step)
      lag_s: 0.3        # the reported velocity is the truth's this much earlier
      standstill: 0.0   # m/s: at or below this true speed the phone reports 0, no course
      sigma_by_speed:   # optional: [true speed m/s, sigma m/s] pairs, speeds increasing
        - [3.0, 0.45]
        - [27.0, 0.05]

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
standstill).

With ``sigma_by_speed`` the error's SD depends on the true speed: linear
between the listed speeds, the end values beyond them. The stream is the
same (``sigma`` times a unit AR(1), so ``phi`` is the persistence of the
error divided by its SD), and each step's error is scaled by
``sigma_by_speed(speed) / sigma``. The measured phones' Doppler velocity
errs 0.2-0.8 m/s in town (1-15 m/s) and 0.05-0.1 m/s on the open road: one
``sigma`` is wrong on both. Without the key the error is as before, bit for
bit.

The velocity error is independent of the position error (the
two come from different observables: Doppler against pseudoranges).
"""

from dataclasses import dataclass

import numpy as np

from gps_error_ros.model import streams

_KEYS = ('lag_s', 'phi', 'sigma', 'standstill')
_OPTIONAL = ('sigma_by_speed',)
#: Most speed nodes a ``sigma_by_speed`` table may have.
MAX_NODES = 32


class VelocityError(ValueError):
    """A ``velocity`` section that is not valid."""


@dataclass(frozen=True)
class Velocity:
    """Velocity error parameters (see module doc)."""

    sigma: float
    phi: float
    lag_s: float
    standstill: float
    sigma_by_speed: tuple = None    # ((speed m/s, sigma m/s), ...), speeds increasing

    def to_dict(self):
        """Return the profile section as plain data."""
        out = {k: float(getattr(self, k)) for k in ('sigma', 'phi', 'lag_s', 'standstill')}
        if self.sigma_by_speed is not None:
            out['sigma_by_speed'] = [[float(v), float(s)] for v, s in self.sigma_by_speed]
        return out

    def sd_at(self, speed):
        """Return the error's SD per component (m/s) at true speeds ``speed``."""
        if self.sigma_by_speed is None:
            return np.full(np.shape(speed), self.sigma)
        return sd_from_table(self.sigma_by_speed, speed)

    def scaled(self, v_true, w):
        """Return the error ``w`` (..., 2) scaled to the SD at the speed of ``v_true``."""
        if self.sigma_by_speed is None:
            return w
        speed = np.hypot(v_true[..., 0], v_true[..., 1])
        return w * (self.sd_at(speed) / self.sigma)[..., None]

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
        v, still = self.vector(v_true, w)
        return np.hypot(v[..., 0], v[..., 1]), np.where(still, np.nan, course_deg(v))

    def vector(self, v_true, w):
        """
        Return (the velocity (..., 2) a phone reports, whether it stands still (...)).

        The truth ``v_true`` (east/north, already ``lag_s`` earlier) plus the
        error ``w`` scaled to the SD at its speed; 0 at or below ``standstill``.
        """
        v_true = np.asarray(v_true, dtype=float)
        still = np.hypot(v_true[..., 0], v_true[..., 1]) <= self.standstill   # NaN: not still
        return np.where(still[..., None], 0.0, v_true + self.scaled(v_true, w)), still


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


def sd_from_table(table, speed):
    """Return a ``sigma_by_speed`` table's SD at ``speed``: linear between, flat beyond."""
    nodes = np.asarray(table, dtype=float)
    return np.interp(np.asarray(speed, dtype=float), nodes[:, 0], nodes[:, 1])


def course_deg(v):
    """Return the direction of east/north velocities (..., 2), degrees clockwise from north."""
    return np.degrees(np.arctan2(v[..., 0], v[..., 1])) % 360.0


def _speed_table(raw, source):
    """Validate ``sigma_by_speed``; return ((speed, sigma), ...)."""
    what = (f'{source}: key velocity.sigma_by_speed: expected a list of 1 to {MAX_NODES} '
            f'[speed m/s, sigma m/s] pairs, speeds in [0, 100] increasing, sigma in (0, 100)')

    def number(v):
        return isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v)

    if not isinstance(raw, (list, tuple)) or not 1 <= len(raw) <= MAX_NODES:
        raise VelocityError(f'{what}, got {raw!r}')
    rows = []
    for pair in raw:
        if not (isinstance(pair, (list, tuple)) and len(pair) == 2 and all(map(number, pair))
                and 0.0 <= pair[0] <= 100.0 and 0.0 < pair[1] < 100.0):
            raise VelocityError(f'{what}, got the pair {pair!r}')
        rows.append((float(pair[0]), float(pair[1])))
    if any(b[0] <= a[0] for a, b in zip(rows, rows[1:])):
        raise VelocityError(f'{what}, got speeds {[r[0] for r in rows]} (not increasing)')
    return tuple(rows)


def velocity_from_dict(raw, source='<profile>'):
    """Validate a ``velocity`` mapping; return :class:`Velocity`."""
    keys = sorted(k for k in raw if k not in _OPTIONAL) if isinstance(raw, dict) else None
    if keys != sorted(_KEYS):
        raise VelocityError(f'{source}: key \'velocity\': expected a mapping with exactly '
                            f'{list(_KEYS)} (and optionally {list(_OPTIONAL)}), got {raw!r}')
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
    if 'sigma_by_speed' in raw:
        vals['sigma_by_speed'] = _speed_table(raw['sigma_by_speed'], source)
    return Velocity(**vals)
