"""``periodic``: a cycle in the innovations' scale and mean (:mod:`~.model.periodic`)."""

from typing import Any

import numpy as np

from gps_error_ros.model.effect_kind import EffectKind, EffectsError, Section, Term
from gps_error_ros.model.periodic import (agent_phases, FIELDS, mean_autocovariance, Periodic,
                                          periodic_from_values, periodic_mean)
from gps_error_ros.model.state import EffectsState, FloatArray, Keys


class CycleTerm(Term):
    """Each agent at its own phase; the AR part carries the cycle's periodic mean."""

    def __init__(self, periodic: Periodic, phi: FloatArray, order: int) -> None:
        self.period = periodic.period
        self.order = order
        self.scales = np.asarray(periodic.scales, dtype=float)
        self.offsets = np.asarray(periodic.offsets, dtype=float)
        self.mean = periodic_mean(phi, self.offsets)
        self.variance_factor = periodic.variance_factor

    def shape(self, state: EffectsState, keys: Keys, index: int, w: FloatArray) -> FloatArray:
        """Return ``w`` scaled and shifted by step ``index``'s phase."""
        phase = (state.cycle_offset + index) % self.period
        state.phase[:] = phase
        return w * self.scales[phase][:, None] + self.offsets[phase]

    def initial(self, state: EffectsState, keys: Keys, index: int) -> None:
        """Place each agent at its phase; its AR lags at their phases' cycle mean."""
        offset = agent_phases(keys, self.period)
        phase = (offset + index) % self.period
        state.cycle_offset[:], state.phase[:] = offset, phase
        for i in range(self.order):
            state.deviations[:, :, i] += self.mean[(phase - i) % self.period]

    def resume(self, state: EffectsState, keys: Keys, index: int) -> None:
        """Place each agent at its phase before step ``index`` (its errors carry the rest)."""
        offset = agent_phases(keys, self.period)
        state.cycle_offset[:] = offset
        state.phase[:] = (offset + index - 1) % self.period

    def autocovariance(self, max_lag: int) -> FloatArray:
        """Return the periodic mean's autocovariance, phase-averaged."""
        return mean_autocovariance(self.mean, max_lag)

    def step_factor(self, state: EffectsState) -> FloatArray:
        """Return the next phase's squared scale."""
        return np.asarray(self.scales[(state.phase + 1) % self.period] ** 2)

    def mean_term(self, state: EffectsState) -> FloatArray:
        """Return the next phase's offset."""
        return np.asarray(self.offsets[(state.phase + 1) % self.period])


class PeriodicKind(EffectKind[Periodic]):
    """A position engine's cycle: scale and offset of the innovations by phase."""

    name = 'periodic'
    fields = FIELDS
    summary = 'a cycle of `period_steps` in the innovations\' scale and mean, by phase'
    order = 5
    stage = 3

    def parse(self, section: Section) -> Periodic:
        """Return the cycle (its rules: :func:`~.model.periodic.periodic_from_values`)."""
        try:
            return periodic_from_values(section.values, section.body, section.source)
        except ValueError as exc:
            raise EffectsError(str(exc)) from None

    def to_dict(self, params: Periodic) -> dict[str, Any]:
        """Return the section."""
        return params.to_dict()

    def term(self, params: Periodic, phi: FloatArray, order: int) -> CycleTerm:
        """Return the cycle's term."""
        return CycleTerm(params, phi, order)


KIND = PeriodicKind()
