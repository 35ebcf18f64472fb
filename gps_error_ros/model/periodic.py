"""
The ``periodic`` effect: a cycle in the innovations (a position engine's).

Profile, under ``effects``::

    periodic:
      period_steps: 8                      # P, model steps (2..MAX_PERIOD)
      scales: [1.4, 0.8, 0.9, 1.0, 1.3, 0.8, 0.9, 0.9]   # SD multiplier by phase
      offsets: [[0.2, -0.1], [-0.1, 0.0], ...]           # (north, east) m by phase

At model step ``k`` an agent is at phase ``j = (k + a) mod P``, ``a`` its own
offset in the cycle (one uniform of the stream domain ``periodic``, so
phones are not in step with each other). The innovation of that step is
``offsets[j] + scales[j] * w(k)``: the variance and the mean of the
innovations follow the cycle. ``offsets`` average zero per axis (``delta``
carries the mean), so the cycle moves the error about the AR mean with the
periodic steady state ``m`` of ``m_j = sum_i phi_i m_{j-i} + offsets[j]``.

Averaged over the phase (what a user who does not know it sees) the process
is stationary: its autocovariance is the AR one with innovation variance
multiplied by ``mean(scales^2)`` plus the autocovariance of ``m``. This is
the covariance published in ``stationary`` mode; ``conditional`` mode uses
the next phase's scale.
"""

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.section_spec import Field, SectionSpec
from gps_error_ros.model.state import FloatArray, IntArray, Keys, Numbers

#: The longest cycle a profile may carry, model steps.
MAX_PERIOD = 120
#: How far from zero the offsets' average per axis may be (m).
OFFSET_MEAN_TOLERANCE = 1e-4


class PeriodicError(ValueError):
    """A ``periodic`` section that does not match the schema."""


@dataclass(frozen=True)
class Periodic:
    """A parsed ``periodic`` effect (see the module docstring)."""

    period: int
    scales: tuple[float, ...]                      # P positive numbers
    offsets: tuple[tuple[float, ...], ...]         # P (north, east) pairs, m

    @property
    def variance_factor(self) -> float:
        """Return the innovation variance multiplier averaged over the cycle."""
        return float(np.mean(np.square(self.scales)))

    def to_dict(self) -> dict[str, Any]:
        """Return the section as plain data."""
        return SECTION.write({'period_steps': self.period, 'scales': self.scales,
                              'offsets': self.offsets})


#: The section's fields; the rules between them (one scale and one offset per phase,
#: offsets averaging 0) are :func:`periodic_from_values`'s.
FIELDS = (
    Field('period_steps', 'the cycle\'s length, model steps', kind='integer', lo=2,
          hi=MAX_PERIOD),
    Field('scales', 'the innovations\' SD multiplier by phase, one per phase', kind='numbers',
          lo=1e-6, hi=1e3, digits=6),
    Field('offsets', 'the innovations\' mean by phase (m), one per phase, averaging 0 per '
          'axis (`delta` carries the mean)', kind='pairs', lo=-1e4, hi=1e4, digits=6))
SECTION = SectionSpec('effects.periodic', FIELDS, PeriodicError)


def periodic_from_values(v: Mapping[str, Any], body: Any, source: str) -> Periodic:
    """
    Return the cycle of a section whose fields :data:`SECTION` has read (``v``).

    What is left to check are the rules between the fields; ``body`` (the
    section as written) is quoted in their errors.
    """
    period = v['period_steps']
    for name, what in (('scales', 'positive numbers (one per phase)'),
                       ('offsets', '[north, east] pairs (m, one per phase)')):
        if len(v[name]) != period:
            raise PeriodicError(f'{source}: key {"effects.periodic." + name!r}: expected a '
                                f'list of {period} {what}, got {body[name]!r}')
    mean = np.mean(np.asarray(v['offsets']), axis=0)
    if np.any(np.abs(mean) > OFFSET_MEAN_TOLERANCE):
        raise PeriodicError(f'{source}: key \'effects.periodic.offsets\': expected offsets '
                            f'averaging 0 per axis (delta carries the mean), got '
                            f'averages {[round(float(x), 6) for x in mean]}')
    return Periodic(period, v['scales'], v['offsets'])


def agent_phases(keys: Keys, period: int) -> IntArray:
    """Return each agent's offset in the cycle (0..period-1), from its own stream."""
    u = streams.uniform_pairs(keys, streams.DOMAIN_PERIODIC, 0)[:, 0]
    return np.minimum((u * period).astype(np.int64), period - 1)


def periodic_mean(phi: Numbers, offsets: Numbers) -> FloatArray:
    """
    Return the periodic steady state ``m`` (P, 2) of the AR recursion.

    ``phi`` (2, p) the AR coefficients per axis, ``offsets`` (P, 2):
    ``m_j = sum_i phi_i m_{(j-i) mod P} + offsets_j`` for every phase ``j``.
    """
    off = np.asarray(offsets, dtype=float)
    period = off.shape[0]
    out = np.empty_like(off)
    for a in range(2):
        mat = np.eye(period)
        for i, ph in enumerate(phi[a]):
            for j in range(period):
                mat[j, (j - i - 1) % period] -= ph
        out[:, a] = np.linalg.solve(mat, off[:, a])
    return out


def mean_autocovariance(m: FloatArray, max_lag: int) -> FloatArray:
    """
    Return the phase-averaged autocovariance of the periodic mean, (max_lag + 1, 2, 2).

    Entry ``[k, i, j]`` is ``mean over t of m_i(t + k) m_j(t)``, the
    convention of :meth:`~.ar_model.ARErrorModel.autocovariance`.
    """
    m = np.asarray(m, dtype=float)
    return np.stack([np.roll(m, -k, axis=0).T @ m / m.shape[0]
                     for k in range(max_lag + 1)])
