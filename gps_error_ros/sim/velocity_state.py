"""
The fix engine's reported velocity, from the truth it holds.

Each agent's velocity error is stepped with its model, and its true velocity
comes from the truth the engine holds.

The true velocity the phone reports at a step's instant ``t`` is the chord
of the truth over one second centred at ``t - lag_s`` (truth interpolated
linearly in time, as for positions), in east/north m/s; the chord never
ends after ``t`` (the truth a step has), so below a lag of 0.5 s it is the
second before ``t``. With a ``course_lag_s`` its direction is that of the
chord centred at ``t - course_lag_s``. ``gps_error simulate`` uses the same
definition (:mod:`velocity_sim`), so both report the same speed and
course. No velocity is reported where the truth does not reach back that far.
"""

from typing import Protocol

import numpy as np

from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.state import BoolArray, FloatArray, IntArray, Keys
from gps_error_ros.model.velocity import Velocity
from gps_error_ros.sim.truth_ring import TruthRing

NS = 1_000_000_000


class SideProcess(Protocol):
    """What a side stream steps: a velocity section's error, a stated accuracy's fluctuation."""

    def initial(self, keys: Keys, index: int) -> FloatArray:
        """Return each agent's value at model step ``index``, (n, d)."""

    def step(self, w: FloatArray, keys: Keys, index: int) -> FloatArray:
        """Return the values ``w`` stepped to model step ``index``."""

    def errors(self, keys: Keys, n_steps: int, start: int = 0) -> FloatArray:
        """Return the values of ``keys`` at ``n_steps`` steps from ``start``, (steps, k, d)."""


class SideStream:
    """
    A per-agent AR(1) stream beside the error (the engine's agents are rows).

    ``process`` has ``initial(keys, index)``, ``step(w, keys, index)`` and
    ``errors(keys, n_steps, start)``, each (n, d): a profile's velocity error
    (d = 2) or its reported accuracy's fluctuation (d = 1).
    """

    def __init__(self, process: SideProcess, n: int) -> None:
        self.process = process
        self.dim = process.initial(np.zeros(1, dtype=np.uint64), 0).shape[1]
        self.w: FloatArray = np.zeros((n, self.dim))

    def start(self, keys: Keys, index: int) -> None:
        """Draw every agent's value at the run's first model step."""
        self.w = self.process.initial(keys, index)

    def advance(self, keys: Keys, index: int) -> None:
        """Step every agent's value to model step ``index``."""
        self.w = self.process.step(self.w, keys, index)

    def grow(self, n: int) -> None:
        """Add ``n`` rows (free slots)."""
        self.w = np.concatenate([self.w, np.zeros((n, self.dim))])

    def history(self, keys: Keys, start: int, end: int) -> FloatArray:
        """Return the values of ``keys`` at model steps start..end, (steps, k, d)."""
        return self.process.errors(keys, end - start + 1, start)


class VelocityState(SideStream):
    """Velocity errors of the engine's agents (rows), one model step at a time."""

    def __init__(self, velocity: Velocity, n: int) -> None:
        super().__init__(velocity, n)
        self.velocity = velocity
        self.lags_ns = [int(round(lag * NS)) for lag in velocity.lags]

    def reported(self, truth: TruthRing, agents: IntArray, t_ns: int, w: FloatArray,
                 max_gap_ns: int) -> tuple[FloatArray, FloatArray, FloatArray | None]:
        """
        Return (velocity (m, 2), its error's SD (m,), mean (m, 2) or None) reported at ``t_ns``.

        ``truth`` is the engine's truth ring, ``w`` the agents' errors at the
        step. NaN rows: the truth does not reach back to the chord's start.
        The SD is the section's at each agent's true speed (``sigma_by_speed``),
        the mean its ``speed_bias`` along the travel, east/north (None without one).
        """
        chords: list[FloatArray] = []
        ok: BoolArray | bool = True
        for lag_ns in self.lags_ns:                        # the speed's, the course's
            end = min(t_ns - lag_ns + NS // 2, t_ns)       # the chord centred at t - lag
            c1, ok1 = truth.interpolate(agents, end, max_gap_ns)
            c0, ok0 = truth.interpolate(agents, end - NS, max_gap_ns)
            ok = ok & ok1 & ok0 & (truth.newest[agents] >= end)
            north, east = difference(c1[:, 0], c1[:, 1], c0[:, 0], c0[:, 1])
            chords.append(np.stack([east, north], axis=1))
        v_true = self.velocity.truth_reported(*chords)
        out, _, mean, sd = self.velocity.report_parts(v_true, w)
        out[~ok] = np.nan
        return out, sd, mean
