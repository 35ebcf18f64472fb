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

from dataclasses import dataclass
import math
from typing import Any

import numpy as np

from gps_error_ros.model import streams
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
        return {'period_steps': int(self.period),
                'scales': [round(float(v), 6) for v in self.scales],
                'offsets': [[round(float(a), 6), round(float(b), 6)]
                            for a, b in self.offsets]}


def _number(source: str, key: str, value: Any, lo: float, hi: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or \
            not math.isfinite(value) or not lo <= value <= hi:
        raise PeriodicError(f'{source}: key {key!r}: expected a number in [{lo}, {hi}], '
                            f'got {value!r}')
    return float(value)


def periodic_from_dict(body: Any, source: str = '<profile>',
                       key: str = 'effects.periodic') -> Periodic:
    """Validate a ``periodic`` mapping (its keys checked by the caller); return it."""
    period = body['period_steps']
    if isinstance(period, bool) or not isinstance(period, int) or \
            not 2 <= period <= MAX_PERIOD:
        raise PeriodicError(f'{source}: key {key + ".period_steps"!r}: expected an '
                            f'integer in [2, {MAX_PERIOD}], got {period!r}')
    scales, offsets = body['scales'], body['offsets']
    if not isinstance(scales, list) or len(scales) != period:
        raise PeriodicError(f'{source}: key {key + ".scales"!r}: expected a list of '
                            f'{period} positive numbers (one per phase), got {scales!r}')
    if not isinstance(offsets, list) or len(offsets) != period or not all(
            isinstance(o, list) and len(o) == 2 for o in offsets):
        raise PeriodicError(f'{source}: key {key + ".offsets"!r}: expected a list of '
                            f'{period} [north, east] pairs (m, one per phase), got '
                            f'{offsets!r}')
    sc = tuple(_number(source, f'{key}.scales[{j}]', v, 1e-6, 1e3)
               for j, v in enumerate(scales))
    off = tuple(tuple(_number(source, f'{key}.offsets[{j}][{a}]', v, -1e4, 1e4)
                      for a, v in enumerate(o)) for j, o in enumerate(offsets))
    mean = np.mean(np.asarray(off), axis=0)
    if np.any(np.abs(mean) > OFFSET_MEAN_TOLERANCE):
        raise PeriodicError(f'{source}: key {key + ".offsets"!r}: expected offsets '
                            f'averaging 0 per axis (delta carries the mean), got '
                            f'averages {[round(float(v), 6) for v in mean]}')
    return Periodic(int(period), sc, off)


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
