"""
Reported accuracy: the radius a phone states about its own fix.

A profile's optional ``reported_accuracy`` section::

    reported_accuracy:
      source: accuracy   # what the phone stated: accuracy (m) or hdop
      median_m: 3.0      # the stated 68 % radius's median (m)
      follow: 0.0        # d log(radius) / d log(the error's scale)
      phi: 0.9           # lag-1 autocorrelation of the radius's own fluctuation
      sigma_log: 0.05    # SD of that fluctuation, in log(radius)
      resolution_m: 1.0  # stated values are multiples of this (0: not rounded)
      scale_m: 0.0       # hdop only: metres of 68 % radius per unit of HDOP

What a phone reports is not what its error is. Android's accuracy is meant
as the radius holding 68 % of the error, but the measured phones state
almost constant values (3-4 m whole metres; an HDOP of 0.38-0.41) whatever
their error does; a user's study of a transmission policy that reads the
stated accuracy needs that, not an honest number. The model::

    log r_k = log(median_m) + follow * log(s_k / s_ref) + x_k
    x_k = phi x_(k-1) + sqrt(1 - phi^2) sigma_log z_k

``s_k`` is the model's own one-step predictive SD of the horizontal error
at step ``k`` (the square root of the covariance's trace: it moves with
variance regimes and zones; at a run's first step, where nothing came
before, the stationary SD, so a cold start states a wider radius),
``s_ref`` the one-step SD averaged over the model's stationary law
(:func:`reference_cov`; for a plain AR model after its first step the two
are equal), so ``follow = 1`` makes the radius scale with the error's scale and
``follow = 0`` ignores it. ``x`` is a stationary AR(1) on the agent's own stream (domain
``reported``; the start from ``init_reported``), so a phone's stated value
drifts and persists as a phone's does. The radius is then rounded to
``resolution_m`` (never below one resolution step), as phones state whole
metres. The lag of a phone's statement behind its error is the
persistence ``phi``; no separate delay is modelled (the measured phones
give none to fit: their statements do not follow their errors at all).

Where a fix needs a covariance (NavSatFix, the accuracy columns) the stated
radius is read as a circular Gaussian's: per-axis SD ``r / 1.5096``, the
factor ``sqrt(-2 ln 0.32)`` that puts 68 % of a 2-D circular Gaussian
inside ``r``; no off-diagonal term (a radius has no orientation).
"""

from dataclasses import dataclass
import math
from typing import Any, Optional

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.protocol import ErrorModel, S
from gps_error_ros.model.section_spec import Field, SectionSpec
from gps_error_ros.model.state import FloatArray, Keys, Numbers
from gps_error_ros.model.velocity import series

#: A 2-D circular Gaussian holds 68 % inside this many per-axis SDs.
R68_PER_SD = math.sqrt(-2.0 * math.log(1.0 - 0.68))


class ReportedError(ValueError):
    """A ``reported_accuracy`` section that is not valid."""


#: The ``reported_accuracy`` section, field by field.
SECTION = SectionSpec('reported_accuracy', (
    Field('source', 'what the phone stated: its accuracy (m) or an HDOP', kind='choice',
          choices=('accuracy', 'hdop')),
    Field('median_m', 'the stated 68 % radius\'s median (m)', lo=0.0, hi=1e4, lo_open=True),
    Field('follow', 'how the radius follows the error\'s scale: d log(radius) / '
          'd log(scale)', lo=-3.0, hi=3.0),
    Field('phi', 'lag-1 autocorrelation of the radius\'s own fluctuation', lo=0.0, hi=0.9999),
    Field('sigma_log', 'SD of that fluctuation, in log(radius)', lo=0.0, hi=5.0),
    Field('resolution_m', 'stated values are multiples of this (0: not rounded)', lo=0.0,
          hi=1e3),
    Field('scale_m', 'hdop only: metres of 68 % radius per unit of HDOP', lo=0.0, hi=1e4),
), ReportedError)


@dataclass(frozen=True)
class ReportedAccuracy:
    """Reported-accuracy parameters (see module doc)."""

    source: str
    median_m: float
    follow: float
    phi: float
    sigma_log: float
    resolution_m: float
    scale_m: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """Return the profile section as plain data."""
        return SECTION.write({f.name: getattr(self, f.name) for f in SECTION.fields})

    def initial(self, keys: Keys, index: int) -> FloatArray:
        """Return the fluctuation ``x`` (n, 1) at a run's first step ``index``."""
        return self.sigma_log * streams.normal_pairs(
            keys, streams.DOMAIN_INIT_REPORTED, index)[:, :1]

    def step(self, x: FloatArray, keys: Keys, index: int) -> FloatArray:
        """Return the fluctuation at step ``index`` after ``x`` at the step before."""
        z = streams.normal_pairs(keys, streams.DOMAIN_REPORTED, index)[:, :1]
        return self.phi * x + math.sqrt(1.0 - self.phi ** 2) * self.sigma_log * z

    def errors(self, keys: Keys, n_steps: int, start: int = 0) -> FloatArray:
        """Return the fluctuation at steps ``start ..``, (n_steps, n, 1)."""
        return series(self, keys, n_steps, start)

    def radius(self, x: Numbers, cov: Optional[Numbers] = None,
               stationary: Optional[Numbers] = None) -> FloatArray:
        """
        Return the stated 68 % radius in metres for fluctuations ``x`` (..., 1).

        ``cov`` (..., 2, 2): the error's predictive covariance at the fix,
        ``stationary`` (2, 2) the profile's; both needed only when ``follow``
        is not 0.
        """
        log_r = math.log(self.median_m) + np.asarray(x, dtype=float)[..., 0]
        if self.follow != 0.0:
            s = np.trace(np.asarray(cov), axis1=-2, axis2=-1)
            s_ref = float(np.trace(np.asarray(stationary)))
            log_r = log_r + 0.5 * self.follow * np.log(np.maximum(s, 1e-12) / s_ref)
        r = np.exp(log_r)
        q = self.resolution_m
        if q > 0:
            r = np.maximum(np.round(r / q), 1.0) * q
        return r

    def covariance(self, radius: Numbers, bias: Optional[Numbers] = None) -> FloatArray:
        """
        Return the north/east covariances, (..., 2, 2), that stated radii imply.

        ``bias`` (2,): an error mean the phone does not know of, added as
        ``bias bias^T`` so that the matrix is about the truth.
        """
        sd2 = (np.asarray(radius, dtype=float) / R68_PER_SD) ** 2
        out = np.zeros(sd2.shape + (2, 2))
        out[..., 0, 0] = out[..., 1, 1] = sd2
        if bias is not None:
            out += np.outer(bias, bias)
        return out

    def stated(self, radius: FloatArray) -> FloatArray:
        """Return what the phone writes: the radius (m), or the HDOP it corresponds to."""
        return radius if self.source == 'accuracy' else radius / self.scale_m


def reported_from_dict(raw: Any, source: str = '<profile>') -> ReportedAccuracy:
    """Validate a ``reported_accuracy`` mapping; return :class:`ReportedAccuracy`."""
    vals = SECTION.read(raw, source)
    if vals['source'] == 'hdop' and vals['scale_m'] <= 0:
        raise ReportedError(f'{source}: key reported_accuracy.scale_m: a phone that states '
                            f'an HDOP needs the metres of 68 % radius per unit (> 0), '
                            f'got {raw["scale_m"]!r}')
    return ReportedAccuracy(**vals)


def reference_cov(model: ErrorModel[S]) -> FloatArray:
    """Return the one-step predictive covariance averaged over the stationary law (``s_ref``)."""
    return model.mean_step_cov()


def needs_predictive(covariance_mode: str, reported: Optional[ReportedAccuracy]) -> bool:
    """Return True when fixes need the predictive covariance (conditional; a following radius)."""
    return covariance_mode == 'conditional' or (
        covariance_mode == 'reported' and reported is not None and reported.follow != 0.0)
