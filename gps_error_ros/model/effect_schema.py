"""
The ``effects`` section of a profile: its schema, parsed into :class:`Effects`.

What each effect does to the error is described in :mod:`effects`, which
simulates them; this module only checks a profile's section against the
schema (names, keys, ranges) and holds the parsed values.
"""

from dataclasses import dataclass
import math
from typing import Any, Optional

import numpy as np

from gps_error_ros.model import outliers as jumps
from gps_error_ros.model.outliers import Outliers
from gps_error_ros.model.periodic import Periodic, periodic_from_dict
from gps_error_ros.model.state import FloatArray, Numbers

EFFECT_NAMES = ('cross_axis_coupling', 'motion_lag', 'heavy_tails',
                'variance_regimes', 'street_frame', 'periodic', 'outliers')
_KEYS = {
    'cross_axis_coupling': ('innovation_corr',),
    'motion_lag': ('lag_s',),
    'heavy_tails': ('dof',),
    'variance_regimes': ('scales', 'transition'),
    'street_frame': ('sigma_along', 'sigma_across'),
    'periodic': ('period_steps', 'scales', 'offsets'),
    'outliers': ('rate', 'mean_steps', 'sigma_m'),
}
#: Metres the truth must move in one second for its direction to count as
#: the direction of travel (street_frame); slower, the last direction holds.
MOVING_M = 0.1
MAX_LAG_S = 10.0
MAX_DOF = 1000.0


class EffectsError(ValueError):
    """An ``effects`` section that does not match the schema."""


def stationary_distribution(transition: Numbers) -> FloatArray:
    """Return the stationary distribution of a row-stochastic matrix."""
    p = np.asarray(transition, dtype=float)
    k = p.shape[0]
    a = np.vstack([p.T - np.eye(k), np.ones(k)])
    b = np.r_[np.zeros(k), 1.0]
    pi = np.linalg.lstsq(a, b, rcond=None)[0]
    return np.clip(pi, 0.0, None) / np.clip(pi, 0.0, None).sum()


@dataclass(frozen=True)
class Effects:
    """Parsed effects (defaults: none of them)."""

    innovation_corr: float = 0.0
    lag_s: float = 0.0
    dof: float = math.inf
    scales: tuple[float, ...] = (1.0,)
    transition: tuple[tuple[float, ...], ...] = ((1.0,),)
    street: Optional[tuple[float, float]] = None        # (sigma_along, sigma_across), m
    periodic: Optional[Periodic] = None
    outliers: Optional[Outliers] = None

    @property
    def names(self) -> tuple[str, ...]:
        """Return the names of the effects present, in schema order."""
        present = (self.innovation_corr != 0.0, self.lag_s != 0.0,
                   math.isfinite(self.dof), len(self.scales) > 1, self.street is not None,
                   self.periodic is not None, self.outliers is not None)
        return tuple(n for n, p in zip(EFFECT_NAMES, present) if p)

    @property
    def regime_probabilities(self) -> FloatArray:
        """Return the regimes' stationary probabilities."""
        return stationary_distribution(self.transition)

    @property
    def variance_factor(self) -> float:
        """Return the average innovation variance multiplier (regimes and cycle)."""
        cycle = 1.0 if self.periodic is None else self.periodic.variance_factor
        return float(self.regime_probabilities @ np.square(self.scales)) * cycle

    def to_dict(self) -> dict[str, Any]:
        """Return the ``effects`` section as plain data (present ones only)."""
        out: dict[str, Any] = {}
        if self.innovation_corr:
            out['cross_axis_coupling'] = {
                'innovation_corr': round(float(self.innovation_corr), 6)}
        if self.lag_s:
            out['motion_lag'] = {'lag_s': round(float(self.lag_s), 4)}
        if math.isfinite(self.dof):
            out['heavy_tails'] = {'dof': round(float(self.dof), 4)}
        if len(self.scales) > 1:
            rows = []
            for i, row in enumerate(self.transition):
                r = [round(float(v), 6) for v in row]
                r[i] = round(1.0 - sum(v for j, v in enumerate(r) if j != i), 6)
                rows.append(r)
            out['variance_regimes'] = {
                'scales': [round(float(v), 6) for v in self.scales],
                'transition': rows}
        if self.street is not None:
            out['street_frame'] = {'sigma_along': round(float(self.street[0]), 6),
                                   'sigma_across': round(float(self.street[1]), 6)}
        if self.periodic is not None:
            out['periodic'] = self.periodic.to_dict()
        if self.outliers is not None:
            out['outliers'] = self.outliers.to_dict()
        return out


def _num(source: str, key: str, value: Any, lo: float, hi: float,
         lo_open: bool = True) -> float:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and \
        math.isfinite(value) and (value > lo if lo_open else value >= lo) and \
        value <= hi
    if not ok:
        bracket = '(' if lo_open else '['
        raise EffectsError(f'{source}: key {key!r}: expected a number in '
                           f'{bracket}{lo}, {hi}], got {value!r}')
    return float(value)


def effects_from_dict(raw: Any, source: str = '<profile>') -> Effects:
    """Validate a profile's ``effects`` mapping; return :class:`Effects`."""
    if raw is None:
        return Effects()
    if not isinstance(raw, dict):
        raise EffectsError(f'{source}: key \'effects\': expected a mapping, '
                           f'got {raw!r}')
    kw: dict[str, Any] = {}
    for name, body in raw.items():
        key = f'effects.{name}'
        if name not in _KEYS:
            raise EffectsError(f'{source}: key {key!r}: unknown effect; '
                               f'expected one of {list(EFFECT_NAMES)}')
        want = _KEYS[name]
        if not isinstance(body, dict) or sorted(body) != sorted(want):
            raise EffectsError(f'{source}: key {key!r}: expected a mapping with '
                               f'exactly {list(want)}, got {body!r}')
        if name == 'cross_axis_coupling':
            kw['innovation_corr'] = _num(source, f'{key}.innovation_corr',
                                         body['innovation_corr'], -0.99, 0.99,
                                         lo_open=False)
        elif name == 'motion_lag':
            kw['lag_s'] = _num(source, f'{key}.lag_s', body['lag_s'], 0.0,
                               MAX_LAG_S)
        elif name == 'heavy_tails':
            kw['dof'] = _num(source, f'{key}.dof', body['dof'], 2.0, MAX_DOF)
        elif name == 'street_frame':
            kw['street'] = tuple(_num(source, f'{key}.{k}', body[k], 0.0, 1e6)
                                 for k in ('sigma_along', 'sigma_across'))
        elif name == 'periodic':
            try:
                kw['periodic'] = periodic_from_dict(body, source, key)
            except ValueError as exc:
                raise EffectsError(str(exc)) from None
        elif name == 'outliers':
            kw['outliers'] = jumps.Outliers(
                _num(source, f'{key}.rate', body['rate'], 0.0, 0.5),
                _num(source, f'{key}.mean_steps', body['mean_steps'], 1.0, 1e3, lo_open=False),
                _num(source, f'{key}.sigma_m', body['sigma_m'], 0.0, jumps.MAX_SIGMA_M))
        else:
            kw.update(_regimes(source, key, body))
    if 'street' in kw and kw.get('innovation_corr'):
        raise EffectsError(f'{source}: key \'effects\': street_frame and '
                           f'cross_axis_coupling both set the innovation covariance; '
                           f'expected one of them')
    return Effects(**kw)


def _regimes(source: str, key: str, body: dict[str, Any]) -> dict[str, Any]:
    scales, trans = body['scales'], body['transition']
    if not isinstance(scales, list) or len(scales) < 2:
        raise EffectsError(f'{source}: key {key + ".scales"!r}: expected a list '
                           f'of at least 2 positive numbers, got {scales!r}')
    scales = tuple(_num(source, f'{key}.scales[{i}]', v, 0.0, 1e3)
                   for i, v in enumerate(scales))
    k = len(scales)
    if not isinstance(trans, list) or len(trans) != k or not all(
            isinstance(r, list) and len(r) == k for r in trans):
        raise EffectsError(f'{source}: key {key + ".transition"!r}: expected a '
                           f'{k}x{k} list of rows (one per scale), got {trans!r}')
    rows = tuple(tuple(_num(source, f'{key}.transition[{i}][{j}]', v, 0.0, 1.0,
                            lo_open=False) for j, v in enumerate(r))
                 for i, r in enumerate(trans))
    for i, r in enumerate(rows):
        if abs(sum(r) - 1.0) > 1e-5:
            raise EffectsError(f'{source}: key {key}.transition[{i}]: expected '
                               f'a row summing to 1, got sum {sum(r)!r}')
    return {'scales': scales, 'transition': rows}
