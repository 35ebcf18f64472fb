"""
Reported speed and course: a phone's Doppler velocity, with its error.

A profile's optional ``velocity`` section::

    velocity:
      sigma: 0.2        # m/s: SD of each east/north component of the velocity error
      phi: 0.75         # the error's lag-1 autocorrelation (per model step)
      lag_s: 0.3        # the reported velocity is the truth's this much earlier
      standstill: 0.0   # m/s: at or below this true speed the phone reports 0, no course
      course_lag_s: 0.6 # optional: the reported course is the truth's this much earlier
      speed_bias:       # optional: [true speed m/s, mean speed error m/s] pairs
        - [7.0, -0.05]
        - [27.0, -0.01]
      sigma_by_speed:   # optional: [true speed m/s, sigma m/s] pairs, speeds increasing
        - [3.0, 0.45]
        - [27.0, 0.05]
      scale_sd_log: 0.2 # optional: SD of the log of an agent's scale of the error
      burst_share: 0.05 # optional, with burst_ratio: the share of steps that burst
      burst_ratio: 5.0  #   and their innovations' SD over the other steps'

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

With ``course_lag_s`` the truth the phone reports has the speed of the
truth ``lag_s`` earlier and the direction of the truth ``course_lag_s``
earlier (where that one stands still, the direction ``lag_s`` earlier): a
phone's speed and course need not lag by the same time (the measured Pixel
4's speed 0.2-0.3 s, its course 0.6 s; decision 0017). Without the key both
lag by ``lag_s``, bit for bit as before.

With ``speed_bias`` the phone's speed errs on average by the table's value
at the true speed (linear between the listed speeds, the end values beyond;
the speed is never below 0): the truth's velocity is lengthened or
shortened along its direction before the error is added. Measured against
the GSDC reference, both phones' speeds were 0.01-0.03 m/s low on the open
road in every part of the drive (decision 0021). Without the key the speed
has no bias, bit for bit as before.

With ``scale_sd_log`` (``s``) each agent's error is its own multiple
``f = exp(s z - s^2)`` of the section's (``z`` standard normal from the
agent's stream, domain ``velocity_scale`` at position 0, so an agent keeps
its scale whenever it starts, alone, in a crowd or in a shard): the
initial error and every innovation are multiplied by ``f``. The mean of
``f^2`` is 1, so the agents' average variance is the section's, and the SD
the node publishes (:meth:`Velocity.sd_at`) is the population's, which a
consumer that does not know the agent's scale needs. The measured phones'
Doppler error changed its scale from one 300-s stretch of a drive to the
next by a log SD of 0.19-0.26 where sampling alone gives 0.08-0.12
(decisions 0026, 0027); one scale for every agent and stretch made their speed
and course spread narrower than the phones' from stretch to stretch.
Without the key every agent has the section's scale, bit for bit as before.

With ``burst_share`` (``p``) and ``burst_ratio`` (``r``) the error is
heavy-tailed: each step's innovation (and the initial error) is a normal
draw times ``c``, ``c = r c0`` on a share ``p`` of the steps (a uniform of
the agent's stream below ``p``: domain ``velocity_burst`` at the step,
``init_velocity_burst`` at the start) and ``c0`` on the others, ``c0 = 1 /
sqrt(1 - p + p r^2)``, so that the error's variance, its SD and its
persistence stay the section's. The measured phones' Doppler error is so on
the open road: most seconds err far less than its RMS and a few far more
(median deviation 0.23-0.58 of the RMS, kurtosis 5.5-52; decision 0027).
Without the keys the error is normal, bit for bit as before.

The velocity error is independent of the position error (the
two come from different observables: Doppler against pseudoranges).
"""

from dataclasses import dataclass
from typing import Any, Optional

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.section_spec import Field, SectionSpec
from gps_error_ros.model.state import BoolArray, FloatArray, Keys, Numbers

#: The largest ``burst_share`` and ``burst_ratio``.
MAX_BURST_SHARE, MAX_BURST_RATIO = 0.5, 100.0
#: Most speed nodes a ``sigma_by_speed`` table may have.
MAX_NODES = 32
#: The largest ``scale_sd_log`` (a factor of e^2 between agents at 1 SD).
MAX_SCALE_SD_LOG = 2.0


class VelocityError(ValueError):
    """A ``velocity`` section that is not valid."""


@dataclass(frozen=True)
class Velocity:
    """Velocity error parameters (see module doc)."""

    sigma: float
    phi: float
    lag_s: float
    standstill: float
    # ((speed m/s, sigma m/s), ...), speeds increasing
    sigma_by_speed: Optional[tuple[tuple[float, float], ...]] = None
    course_lag_s: Optional[float] = None      # s: the course's own lag (None: ``lag_s``)
    # ((speed m/s, mean speed error m/s), ...)
    speed_bias: Optional[tuple[tuple[float, float], ...]] = None
    scale_sd_log: Optional[float] = None      # SD of the log of an agent's scale (None: one scale)
    burst_share: Optional[float] = None       # share of steps whose innovation bursts
    burst_ratio: Optional[float] = None       # the bursts' innovation SD over the other steps'

    def to_dict(self) -> dict[str, Any]:
        """Return the profile section as plain data."""
        return SECTION.write({f.name: getattr(self, f.name) for f in FIELDS})

    @property
    def lags(self) -> tuple[float, ...]:
        """Return the times (s) the truth is taken back by: the speed's, and any course's."""
        if self.course_lag_s is None:
            return (self.lag_s,)
        return (self.lag_s, self.course_lag_s)

    def truth_reported(self, v_speed: Numbers, v_course: Numbers = None) -> FloatArray:
        """
        Return the true velocity (..., 2) the phone reports, from the truth at its lags.

        ``v_speed``: the truth ``lag_s`` earlier; ``v_course``: ``course_lag_s``
        earlier (ignored without it). The result has the speed of the first and
        the direction of the second, or of the first where the second stands still.
        """
        if self.course_lag_s is None:
            return v_speed
        return speed_along(v_speed, v_course)

    def sd_at(self, speed: Numbers) -> FloatArray:
        """Return the error's SD per component (m/s) at true speeds ``speed``."""
        if self.sigma_by_speed is None:
            return np.full(np.shape(speed), self.sigma)
        return sd_from_table(self.sigma_by_speed, speed)

    def scaled(self, v_true: Numbers, w: FloatArray, speed: Numbers = None,
               sd: Numbers = None) -> FloatArray:
        """
        Return the error ``w`` (..., 2) scaled to the SD at the speed of ``v_true``.

        ``speed`` and ``sd`` (:meth:`sd_at` of it), where the caller has them.
        """
        if self.sigma_by_speed is None:
            return w
        if sd is None:
            sd = self.sd_at(np.hypot(v_true[..., 0], v_true[..., 1]) if speed is None else speed)
        return w * (sd / self.sigma)[..., None]

    def agent_sds(self, keys: Keys) -> Any:
        """
        Return each agent's ``sigma`` times its scale ``f`` (n, 1), or ``sigma`` without one.

        The scales of the last ``keys`` asked for are kept: a run steps the
        same agents step after step, and the draw would otherwise cost as
        much as the step's own.
        """
        if self.scale_sd_log is None:
            return self.sigma
        tag = np.asarray(keys, dtype=np.uint64).tobytes()
        kept = self.__dict__.get('_kept_sds')
        if kept is not None and kept[0] == tag:
            return kept[1]
        z = streams.normal_pairs(keys, streams.DOMAIN_VELOCITY_SCALE, 0)[:, :1]
        s = self.scale_sd_log
        sds = self.sigma * np.exp(s * z - s * s)
        sds.setflags(write=False)
        object.__setattr__(self, '_kept_sds', (tag, sds))   # (frozen: not a field)
        return sds

    def bursts(self, z: FloatArray, keys: Keys, domain: int, index: Any) -> FloatArray:
        """Return the draws ``z`` (n, 2) times each agent's burst factor (no bursts: ``z``)."""
        if self.burst_share is None:
            return z
        p, r = self.burst_share, float(self.burst_ratio or 1.0)
        c0 = 1.0 / np.sqrt(1.0 - p + p * r * r)
        u = streams.uniform_pairs(keys, domain, index)[:, :1]
        return z * np.where(u < p, r * c0, c0)

    def initial(self, keys: Keys, index: int) -> FloatArray:
        """Return the error (n, 2) east/north at a run's first step ``index``."""
        z = self.bursts(streams.normal_pairs(keys, streams.DOMAIN_INIT_VELOCITY, index), keys,
                        streams.DOMAIN_INIT_VELOCITY_BURST, index)
        return self.agent_sds(keys) * z

    def step(self, w: FloatArray, keys: Keys, index: int) -> FloatArray:
        """Return the error at step ``index`` after ``w`` at the step before."""
        z = self.bursts(streams.normal_pairs(keys, streams.DOMAIN_VELOCITY, index), keys,
                        streams.DOMAIN_VELOCITY_BURST, index)
        return self.phi * w + np.sqrt(1.0 - self.phi ** 2) * self.agent_sds(keys) * z

    def errors(self, keys: Keys, n_steps: int, start: int = 0) -> FloatArray:
        """Return the velocity errors at steps ``start ..``, (n_steps, n, 2) east/north m/s."""
        return series(self, keys, n_steps, start)

    def report(self, v_true: Numbers, w: FloatArray) -> tuple[FloatArray, FloatArray]:
        """
        Return (speed m/s, course deg) a phone reports for true velocity ``v_true``.

        ``v_true`` and ``w`` are (..., 2) east/north, the truth already taken
        at the section's lags (:meth:`truth_reported`). At or below
        ``standstill`` the speed is 0 and the course NaN.
        """
        v, still = self.vector(v_true, w)
        return np.hypot(v[..., 0], v[..., 1]), np.where(still, np.nan, course_deg(v))

    def vector(self, v_true: Numbers, w: FloatArray) -> tuple[FloatArray, BoolArray]:
        """
        Return (the velocity (..., 2) a phone reports, whether it stands still (...)).

        The truth ``v_true`` (east/north, already at the lags) plus the
        error ``w`` scaled to the SD at its speed; 0 at or below ``standstill``.
        """
        v, still, _ = self.vector_and_mean(v_true, w)
        return v, still

    def mean_error(self, v_true: Numbers) -> FloatArray:
        """Return the error's mean (..., 2) at true velocities ``v_true``: the speed bias."""
        v_true = np.asarray(v_true, dtype=float)
        speed = np.hypot(v_true[..., 0], v_true[..., 1])
        still = speed <= self.standstill                # NaN: not still
        return np.where(still[..., None], 0.0, self.biased(v_true, speed) - v_true)

    def vector_and_mean(self, v_true: Numbers,
                        w: FloatArray) -> tuple[FloatArray, BoolArray, Optional[FloatArray]]:
        """
        Return (what :meth:`vector` returns, and :meth:`mean_error` or None), in one pass.

        The speed and the biased truth are taken once for the three; the
        mean only with a ``speed_bias`` (None without one, where it is 0).
        """
        v, still, mean, _ = self.report_parts(v_true, w)
        return v, still, mean

    def report_parts(self, v_true: Numbers,
                     w: FloatArray
                     ) -> tuple[FloatArray, BoolArray, Optional[FloatArray], FloatArray]:
        """
        Return (:meth:`vector_and_mean`'s three, and the error's SD (...) at the true speed).

        The node's step: the speed taken once, and the SD at it once, for
        the error's scaling and the published covariance alike.
        """
        v_true = np.asarray(v_true, dtype=float)
        speed = np.hypot(v_true[..., 0], v_true[..., 1])
        still = speed <= self.standstill                # NaN: not still
        biased = self.biased(v_true, speed)
        sd = self.sd_at(speed)
        v = np.where(still[..., None], 0.0, biased + self.scaled(v_true, w, speed, sd))
        if self.speed_bias is None:
            return v, still, None, sd
        return v, still, np.where(still[..., None], 0.0, biased - v_true), sd

    def biased(self, v_true: Numbers, speed: Numbers = None) -> FloatArray:
        """Return ``v_true`` (..., 2) with its speed moved by ``speed_bias`` (never below 0)."""
        if self.speed_bias is None:
            return v_true
        return with_speed_bias(v_true, self.speed_bias, speed)


def series(process: Any, keys: Keys, n_steps: int, start: int = 0) -> FloatArray:
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


def with_speed_bias(v_true: Numbers, table: tuple[tuple[float, float], ...],
                    speed: Numbers = None) -> FloatArray:
    """Return ``v_true`` (..., 2) lengthened by a speed table's bias at its speed (not below 0)."""
    if speed is None:
        speed = np.hypot(v_true[..., 0], v_true[..., 1])
    bias = sd_from_table(table, speed)
    gain = np.maximum(speed + bias, 0.0) / np.where(speed > 0.0, speed, 1.0)
    return v_true * np.where(speed > 0.0, gain, 1.0)[..., None]


def speed_along(v_speed: Numbers, v_course: Numbers) -> FloatArray:
    """
    Return velocities (..., 2) with the speed of ``v_speed`` and the direction of ``v_course``.

    Where ``v_course`` stands still the result is ``v_speed``; where it is
    unknown (NaN), NaN.
    """
    v_speed, v_course = np.asarray(v_speed, dtype=float), np.asarray(v_course, dtype=float)
    speed = np.hypot(v_speed[..., 0], v_speed[..., 1])
    toward = np.hypot(v_course[..., 0], v_course[..., 1])
    moving = toward > 0.0                              # NaN: not moving
    turned = v_course * (speed / np.where(moving, toward, 1.0))[..., None]
    out = np.where(moving[..., None], turned, v_speed)
    out[~np.isfinite(toward)] = np.nan                 # the course's truth is unknown
    return out


def sd_from_table(table: tuple[tuple[float, float], ...], speed: Numbers) -> FloatArray:
    """Return a speed table's value (SD, bias) at ``speed``: linear between, flat beyond."""
    nodes = np.asarray(table, dtype=float)
    return np.interp(np.asarray(speed, dtype=float), nodes[:, 0], nodes[:, 1])


def course_deg(v: FloatArray) -> FloatArray:
    """Return the direction of east/north velocities (..., 2), degrees clockwise from north."""
    return np.degrees(np.arctan2(v[..., 0], v[..., 1])) % 360.0


#: The section's fields, in the order it is written; that bursts come both or neither is
#: :func:`velocity_from_dict`'s rule.
FIELDS = (
    Field('sigma', 'the error\'s SD per component (m/s)', lo=0.0, hi=100.0, lo_open=True,
          hi_open=True),
    Field('phi', 'its lag-1 correlation; with `sigma_by_speed`, the persistence in units of '
          'the SD', lo=-1.0, hi=1.0, lo_open=True, hi_open=True),
    Field('lag_s', 'the reported speed is the truth\'s `lag_s` earlier (s)', hi=10.0),
    Field('standstill', 'at or below this true speed (m/s) the phone reports 0 and no course',
          hi=100.0),
    Field('sigma_by_speed', 'the error\'s SD by true speed', kind='by_speed', lo=0.0,
          hi=100.0, lo_open=True, hi_open=True, most=MAX_NODES, absent='`sigma`'),
    Field('course_lag_s', 'the reported direction is the truth\'s that much earlier (s)',
          hi=10.0, absent='`lag_s`'),
    Field('speed_bias', 'a mean error along the travel by true speed (never below 0)',
          kind='by_speed', lo=-100.0, hi=100.0, lo_open=True, hi_open=True, most=MAX_NODES,
          absent='none'),
    Field('scale_sd_log', '`s`: each agent\'s error is its own multiple `exp(s z - s^2)` of '
          'the section\'s', hi=MAX_SCALE_SD_LOG, absent='one scale'),
    Field('burst_share', '`p`, with `burst_ratio`: the share of steps whose innovation is `r` '
          'times the others\', at the same SD', hi=MAX_BURST_SHARE, lo_open=True,
          absent='none'),
    Field('burst_ratio', '`r`, with `burst_share`', lo=1.0, hi=MAX_BURST_RATIO, lo_open=True,
          absent='none'))
SECTION = SectionSpec('velocity', FIELDS, VelocityError)


def velocity_from_dict(raw: Any, source: str = '<profile>') -> Velocity:
    """Validate a ``velocity`` mapping as :data:`SECTION` declares it; return :class:`Velocity`."""
    vals = SECTION.read(raw, source)
    if (vals['burst_share'] is None) != (vals['burst_ratio'] is None):
        raise VelocityError(f'{source}: key velocity.burst_share and burst_ratio: expected '
                            f'both or neither, got {raw.get("burst_share")!r} and '
                            f'{raw.get("burst_ratio")!r}')
    return Velocity(**vals)
