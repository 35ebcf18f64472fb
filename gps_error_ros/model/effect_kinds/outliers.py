"""``outliers``: jumps held for a few steps, outside the AR recursion (:mod:`~.model.outliers`)."""

from typing import Any

import numpy as np

from gps_error_ros.model import outliers as jumps
from gps_error_ros.model.effect_kind import EffectKind, Section, Term
from gps_error_ros.model.section_spec import Field
from gps_error_ros.model.outliers import Outliers
from gps_error_ros.model.state import EffectsState, FloatArray, Keys


class JumpTerm(Term):
    """A jump's offset, added to the error while it lasts; it does not persist after."""

    def __init__(self, outliers: Outliers) -> None:
        self.outliers = outliers

    def output(self, state: EffectsState, keys: Keys, index: int,
               errors: FloatArray) -> FloatArray:
        """Step each agent's jump; return ``errors`` with its offset."""
        jumps.advance_offsets(self.outliers, state.in_jump, state.jump, keys, index)
        return errors + state.jump

    def current(self, state: EffectsState, errors: FloatArray) -> FloatArray:
        """Return ``errors`` with the jump under way."""
        return errors + state.jump

    def initial(self, state: EffectsState, keys: Keys, index: int) -> None:
        """Draw a jump under way from the stationary law."""
        state.in_jump[:], state.jump[:] = jumps.initial_offsets(self.outliers, keys, index)

    def autocovariance(self, max_lag: int) -> FloatArray:
        """Return the jumps' autocovariance: the same on both axes, uncorrelated between."""
        return np.asarray(self.outliers.autocovariance(max_lag)[:, None, None] * np.eye(2))

    def added_cov(self, state: EffectsState, first: bool) -> FloatArray:
        """Return the next offset's covariance given the jump state."""
        return jumps.offset_cov(self.outliers, state.in_jump, state.jump, first=first)

    def mean_term(self, state: EffectsState) -> FloatArray:
        """Return what is left of a jump under way (kept with probability ``1 - q``)."""
        return np.asarray((1.0 - self.outliers.end_probability) *
                          (state.in_jump > 0.5)[:, None] * state.jump)


class OutliersKind(EffectKind[Outliers]):
    """Jumps: at a rate per step, an offset held for a geometric number of steps."""

    name = 'outliers'
    fields = (Field('rate', 'jumps starting per step', lo=0.0, hi=0.5, lo_open=True, digits=8),
              Field('mean_steps', 'steps a jump is held on average', lo=1.0, hi=1e3, digits=6),
              Field('sigma_m', 'SD of a jump per axis, m', lo=0.0, hi=jumps.MAX_SIGMA_M,
                    lo_open=True, digits=6))
    summary = ('jumps at `rate` per step, held `mean_steps` on average, SD `sigma_m` m; '
               'outside the AR recursion')
    order = 6
    stage = 4

    def parse(self, section: Section) -> Outliers:
        """Return the jumps' law."""
        return Outliers(*(section.number(k) for k in self.keys))

    def to_dict(self, params: Outliers) -> dict[str, Any]:
        """Return the section."""
        return self.spec.write({key: getattr(params, key) for key in self.keys})

    def term(self, params: Outliers, phi: FloatArray, order: int) -> JumpTerm:
        """Return the jumps' term."""
        return JumpTerm(params)


KIND = OutliersKind()
