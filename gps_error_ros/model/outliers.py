"""
The ``outliers`` effect: the reported fix jumps away for a few fixes, and back.

Profile, under ``effects``::

    outliers:
      rate: 0.01          # per model step, the chance that a clean fix starts a jump
      mean_steps: 2.0     # the jumps' mean length, model steps (>= 1)
      sigma_m: 12.0       # the SD of the jump per axis, m

A reflection caught for a fix or a few: the reported error is the AR error
plus an offset ``o(k)`` that is zero on clean steps. A clean step starts a
jump with probability ``rate``; the jump's offset, drawn once, is
``N(0, sigma_m^2)`` per axis (north and east independent) and holds while
the jump lasts; each following step ends it with probability ``q = 1 /
mean_steps`` (lengths geometric on 1, 2, ...). The offset does not enter
the AR recursion: unlike a heavy-tailed innovation, a jump does not persist
through ``phi`` once it ends.

The offset is a two-state Markov chain (clean, in a jump) times a held
Gaussian, so its contribution to the error's autocovariance is exact:
``pi (1 - q)^k sigma_m^2`` at lag ``k`` per axis (none across axes), with
``pi = rate / (rate + q)`` the share of steps in a jump.

Draws: the start-or-end uniform from the stream domain ``outlier``, the
offset's normal pair from ``outlier_jump``, one position per model step; the
initial state's from ``init_outlier`` and ``init_outlier_jump``.
"""

from dataclasses import dataclass

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.state import FloatArray, Keys

#: The largest jump SD a profile may carry (m).
MAX_SIGMA_M = 1e4


@dataclass(frozen=True)
class Outliers:
    """A parsed ``outliers`` effect (see the module docstring)."""

    rate: float
    mean_steps: float
    sigma_m: float

    @property
    def end_probability(self) -> float:
        """Return q, the chance per step that a jump under way ends."""
        return 1.0 / self.mean_steps

    @property
    def share(self) -> float:
        """Return the stationary share of steps in a jump."""
        return self.rate / (self.rate + self.end_probability)

    def autocovariance(self, max_lag: int) -> FloatArray:
        """Return the offset's autocovariance per axis at lags 0..max_lag, (max_lag + 1,)."""
        k = np.arange(max_lag + 1)
        return self.share * (1.0 - self.end_probability) ** k * self.sigma_m ** 2


def initial_offsets(outliers: Outliers, keys: Keys,
                    index: int) -> tuple[FloatArray, FloatArray]:
    """
    Return (remaining flag, offsets) of agents started at model step ``index``.

    In a jump with the stationary share, its offset ``N(0, sigma_m^2)``;
    flag 1.0 in a jump, 0.0 clean; offsets (n, 2), zero when clean.
    """
    u = streams.uniform_pairs(keys, streams.DOMAIN_INIT_OUTLIER, index)[:, 0]
    inside = u < outliers.share
    z = streams.normal_pairs(keys, streams.DOMAIN_INIT_OUTLIER_JUMP, index)
    return inside.astype(float), np.where(inside[:, None], z * outliers.sigma_m, 0.0)


def advance_offsets(outliers: Outliers, inside: FloatArray, offsets: FloatArray,
                    keys: Keys, index: int) -> FloatArray:
    """
    Advance the jump state to model step ``index`` in place; return the offsets.

    ``inside`` (n,) 1.0 in a jump, ``offsets`` (n, 2) m: a jump under way
    ends with probability q, a clean step starts one with probability rate
    (a jump that ends leaves this step clean).
    """
    u = streams.uniform_pairs(keys, streams.DOMAIN_OUTLIER, index)[:, 0]
    was = inside > 0.5
    ends = was & (u < outliers.end_probability)
    starts = ~was & (u < outliers.rate)
    if starts.any():
        z = streams.normal_pairs(keys[starts], streams.DOMAIN_OUTLIER_JUMP, index)
        offsets[starts] = z * outliers.sigma_m
    offsets[ends] = 0.0
    inside[:] = ((was & ~ends) | starts).astype(float)
    return offsets


def offset_cov(outliers: Outliers, inside: FloatArray, offsets: FloatArray,
               first: bool = False) -> FloatArray:
    """
    Return the covariance (n, 2, 2) of the next step's offset given the jump state.

    Clean: a jump starts with probability rate, ``rate sigma_m^2 I``. In a
    jump with offset ``o``: kept with probability ``1 - q``, else zero,
    ``q (1 - q) o o^T``. ``first``: the stationary law, ``pi sigma_m^2 I``.
    """
    n = inside.shape[0]
    eye = np.eye(2)[None]
    if first:
        return np.repeat(eye * outliers.share * outliers.sigma_m ** 2, n, axis=0)
    q = outliers.end_probability
    clean = eye * outliers.rate * outliers.sigma_m ** 2
    held = q * (1.0 - q) * offsets[:, :, None] * offsets[:, None, :]
    return np.where((inside > 0.5)[:, None, None], held, clean)
