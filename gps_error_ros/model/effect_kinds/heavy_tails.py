"""``heavy_tails``: the innovations are Student-t with ``dof`` degrees of freedom."""

import math

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.effect_kind import OneNumber, Term
from gps_error_ros.model.section_spec import Field
from gps_error_ros.model.state import EffectsState, FloatArray, Keys

#: The most degrees of freedom a profile may carry (beyond, all but Gaussian).
MAX_DOF = 1000.0


class HeavyTailTerm(Term):
    """One shared chi-square mixing per step: a jump moves both axes; the covariance is kept."""

    def __init__(self, dof: float) -> None:
        self.dof = dof

    def shape(self, state: EffectsState, keys: Keys, index: int, w: FloatArray) -> FloatArray:
        """Return ``w`` scaled by the step's mixing draw (unit variance kept)."""
        u = streams.uniform_pairs(keys, streams.DOMAIN_TAIL, index)[:, 0]
        half = 0.5 * self.dof
        from scipy import special       # here: a node without tails need not import scipy
        mix = special.gammaincinv(half, u) / half        # chi2(dof) / dof
        w *= np.sqrt((self.dof - 2.0) / self.dof / mix)[:, None]
        return w


class HeavyTails(OneNumber):
    """Bivariate Student-t innovations, scaled to the AR part's covariance."""

    name = 'heavy_tails'
    summary = 'Student-t innovations with `dof` degrees of freedom (one mixing draw per step)'
    fields = (Field('dof', 'the degrees of freedom', lo=2.0, hi=MAX_DOF, lo_open=True,
                    digits=4),)
    order = 2
    stage = 2
    none = math.inf

    def absent(self, params: float) -> bool:
        """Return True for infinite degrees of freedom (Gaussian)."""
        return not math.isfinite(params)

    def term(self, params: float, phi: FloatArray, order: int) -> HeavyTailTerm:
        """Return the step's mixing."""
        return HeavyTailTerm(float(params))


KIND = HeavyTails()
