"""``street_frame``: the innovations lie along and across the direction of travel."""

import math
from typing import Any

import numpy as np

from gps_error_ros.model.ar_model import AxisParams
from gps_error_ros.model.effect_kind import EffectKind, Section, Term
from gps_error_ros.model.section_spec import Field
from gps_error_ros.model.state import EffectsState, FloatArray

Street = tuple[float, float]


class StreetTerm(Term):
    """Innovations turned to each agent's direction of travel (its ``heading``)."""

    def __init__(self, street: Street) -> None:
        self.along_sd, self.across_sd = street

    def innovations(self, state: EffectsState, z: FloatArray) -> FloatArray:
        """Return the innovations along/across each agent's heading, as north/east."""
        theta = state.heading
        c, s = np.cos(theta), np.sin(theta)
        along, across = self.along_sd * z[:, 0], self.across_sd * z[:, 1]
        return np.stack([along * c - across * s, along * s + across * c], axis=1)

    def innovation_cov(self, state: EffectsState) -> FloatArray:
        """Return each agent's innovation covariance (n, 2, 2) in its direction of travel."""
        theta = state.heading
        c, s = np.cos(theta), np.sin(theta)
        a2, x2 = self.along_sd ** 2, self.across_sd ** 2
        out = np.empty((theta.size, 2, 2))
        out[:, 0, 0] = a2 * c * c + x2 * s * s
        out[:, 1, 1] = a2 * s * s + x2 * c * c
        out[:, 0, 1] = out[:, 1, 0] = (a2 - x2) * c * s
        return out


class StreetFrame(EffectKind[Street]):
    """The error ellipse turns with the walker; the AR coefficients stay per axis."""

    name = 'street_frame'
    fields = (Field('sigma_along', 'innovation SD along the direction of travel, m', lo=0.0,
                    hi=1e6, lo_open=True, digits=6),
              Field('sigma_across', 'innovation SD across it, m', lo=0.0, hi=1e6, lo_open=True,
                    digits=6))
    summary = 'innovations along and across the direction of travel (SDs in m)'
    order = 4
    needs_heading = True
    sets_innovations = True

    def parse(self, section: Section) -> Street:
        """Return the SDs along and across, m."""
        along, across = (section.number(k) for k in self.keys)
        return along, across

    def to_dict(self, params: Street) -> dict[str, Any]:
        """Return the section."""
        return self.spec.write(dict(zip(self.keys, params)))

    def ar(self, params: Street, north: AxisParams, east: AxisParams,
           corr: float) -> tuple[AxisParams, AxisParams, float]:
        """Return the axes with the innovation SD averaged over directions."""
        sw = math.sqrt(0.5 * (params[0] ** 2 + params[1] ** 2))
        return AxisParams(north.delta, north.phi, sw), AxisParams(east.delta, east.phi, sw), corr

    def term(self, params: Street, phi: FloatArray, order: int) -> StreetTerm:
        """Return the turned innovations."""
        return StreetTerm(params)


KIND = StreetFrame()
