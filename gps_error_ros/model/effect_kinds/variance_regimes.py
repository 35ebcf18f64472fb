"""``variance_regimes``: a Markov chain of regimes, each scaling the innovations."""

from dataclasses import dataclass
from typing import Any

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.effect_kind import EffectKind, Section, Term
from gps_error_ros.model.section_spec import Field
from gps_error_ros.model.state import EffectsState, FloatArray, Keys, Numbers


def stationary_distribution(transition: Numbers) -> FloatArray:
    """Return the stationary distribution of a row-stochastic matrix."""
    p = np.asarray(transition, dtype=float)
    k = p.shape[0]
    a = np.vstack([p.T - np.eye(k), np.ones(k)])
    b = np.r_[np.zeros(k), 1.0]
    pi = np.linalg.lstsq(a, b, rcond=None)[0]
    return np.clip(pi, 0.0, None) / np.clip(pi, 0.0, None).sum()


@dataclass(frozen=True)
class Regimes:
    """The regimes' innovation scales and the chain's row-stochastic transition matrix."""

    scales: tuple[float, ...]
    transition: tuple[tuple[float, ...], ...]

    @property
    def probabilities(self) -> FloatArray:
        """Return the regimes' stationary probabilities."""
        return stationary_distribution(self.transition)


class RegimeTerm(Term):
    """The chain steps before the innovation it scales; a run starts from its stationary law."""

    def __init__(self, regimes: Regimes) -> None:
        self.scales = np.asarray(regimes.scales, dtype=float)
        self.transition = np.asarray(regimes.transition)
        self.cum_transition = np.cumsum(self.transition, axis=1)
        self.cum_transition[:, -1] = 1.0
        self.pi = regimes.probabilities
        self.cum_pi = np.cumsum(self.pi)
        self.cum_pi[-1] = 1.0
        self.variance_factor = float(self.pi @ np.square(regimes.scales))

    def shape(self, state: EffectsState, keys: Keys, index: int, w: FloatArray) -> FloatArray:
        """Step each agent's regime; return ``w`` scaled by the new regime's scale."""
        u = streams.uniform_pairs(keys, streams.DOMAIN_REGIME, index)[:, 0]
        nxt = (u[:, None] >= self.cum_transition[state.regime]).sum(axis=1)
        nxt = np.minimum(nxt, self.scales.size - 1)
        state.regime[:] = nxt
        w *= self.scales[nxt][:, None]
        return w

    def initial(self, state: EffectsState, keys: Keys, index: int) -> None:
        """Draw each agent's regime from the stationary law."""
        u = streams.uniform_pairs(keys, streams.DOMAIN_INIT_REGIME, index)[:, 0]
        state.regime[:] = np.searchsorted(self.cum_pi, u, side='right')

    def step_factor(self, state: EffectsState) -> FloatArray:
        """Return the next step's expected squared scale given the current regime."""
        return np.asarray(self.transition[state.regime] @ self.scales ** 2)


class VarianceRegimes(EffectKind[Regimes]):
    """Calm and disturbed stretches: the innovations' scale follows a Markov chain."""

    name = 'variance_regimes'
    fields = (Field('scales', 'each regime\'s scale of the innovations (2 or more)',
                    'numbers', lo=0.0, hi=1e3, lo_open=True),
              Field('transition', 'the chain\'s transition matrix, one row per regime, each '
                    'summing to 1', 'rows', lo=0.0, hi=1.0))
    summary = 'a Markov chain over regimes, each scaling the innovations'
    order = 3
    stage = 1

    def parse(self, section: Section) -> Regimes:
        """Return the regimes: two scales or more, and a square row-stochastic matrix."""
        values, rows = section.table('scales'), section.table('transition')
        if len(values) < 2:
            raise section.fail(f'.scales: expected a list of at least 2 positive numbers, '
                               f'got {list(values)!r}')
        k = len(values)
        if len(rows) != k or not all(len(r) == k for r in rows):
            raise section.fail(f'.transition: expected a {k}x{k} list of rows (one per '
                               f'scale), got {[list(r) for r in rows]!r}')
        for i, r in enumerate(rows):
            if abs(sum(r) - 1.0) > 1e-5:
                raise section.fail(f'.transition[{i}]: expected a row summing to 1, '
                                   f'got sum {sum(r)!r}')
        return Regimes(values, rows)

    def to_dict(self, params: Regimes) -> dict[str, Any]:
        """Return the section, each row's diagonal making its sum 1 after rounding."""
        rows = []
        for i, row in enumerate(params.transition):
            r = [round(float(v), 6) for v in row]
            r[i] = round(1.0 - sum(v for j, v in enumerate(r) if j != i), 6)
            rows.append(r)
        return {'scales': [round(float(v), 6) for v in params.scales], 'transition': rows}

    def absent(self, params: Regimes) -> bool:
        """Return True for one regime."""
        return len(params.scales) <= 1

    def term(self, params: Regimes, phi: FloatArray, order: int) -> RegimeTerm:
        """Return the chain's term."""
        return RegimeTerm(params)


KIND = VarianceRegimes()
