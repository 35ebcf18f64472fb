"""
The ``effects`` section of a profile, read through the registry of effects.

Each effect's keys, checks and defaults are its kind's
(:mod:`~.effect_kinds`); this module reads and writes the section as a whole:
unknown names, at most one effect that sets the innovations, the order in
which a profile writes them.
"""

from collections.abc import Iterator, Mapping
from typing import Any, Optional

import numpy as np

from gps_error_ros.model.effect_kind import EffectKind, EffectsError, Section
from gps_error_ros.model.effect_kinds import BY_NAME, EFFECT_NAMES, KINDS
from gps_error_ros.model.effect_kinds.heavy_tails import MAX_DOF
from gps_error_ros.model.effect_kinds.motion_lag import MAX_LAG_S
from gps_error_ros.model.effect_kinds.street_frame import Street
from gps_error_ros.model.effect_kinds.variance_regimes import Regimes, stationary_distribution
from gps_error_ros.model.outliers import Outliers
from gps_error_ros.model.periodic import Periodic
from gps_error_ros.model.state import FloatArray

__all__ = ['EFFECT_NAMES', 'Effects', 'EffectsError', 'MAX_DOF', 'MAX_LAG_S', 'MOVING_M',
           'effects_from_dict', 'stationary_distribution']

#: Metres the truth must move in one second for its direction to count as
#: the direction of travel (street_frame); slower, the last direction holds.
MOVING_M = 0.1


class Effects:
    """
    A profile's effects: each present effect's parameters, by name, in schema order.

    ``Effects({'heavy_tails': 4.5})``; ``effects['heavy_tails']``; ``'periodic'
    in effects``. The accessors below give the built-in effects' parameters,
    or what their absence means (no lag, Gaussian, one regime, ...).
    """

    __slots__ = ('_params',)

    def __init__(self, params: Optional[Mapping[str, Any]] = None) -> None:
        params = dict(params or {})
        unknown = sorted(set(params) - set(BY_NAME))
        if unknown:
            raise EffectsError(f'effects: unknown effect {unknown[0]!r}; expected one of '
                               f'{list(EFFECT_NAMES)}')
        self._params = tuple((k.name, params[k.name]) for k in KINDS
                             if k.name in params and not k.absent(params[k.name]))

    def __getitem__(self, name: str) -> Any:
        """Return the parameters of effect ``name`` (KeyError when absent)."""
        for key, value in self._params:
            if key == name:
                return value
        raise KeyError(name)

    def __contains__(self, name: object) -> bool:
        """Return True when effect ``name`` is present."""
        return any(key == name for key, _ in self._params)

    def __iter__(self) -> Iterator[tuple[EffectKind[Any], Any]]:
        """Yield (kind, parameters) of the present effects, in schema order."""
        return ((BY_NAME[k], v) for k, v in self._params)

    def __eq__(self, other: object) -> bool:
        """Return True for the same effects with the same parameters."""
        return isinstance(other, Effects) and self._params == other._params

    def __hash__(self) -> int:
        """Return a hash of the parameters."""
        return hash(self._params)

    def __repr__(self) -> str:
        """Return ``Effects({...})``."""
        return f'Effects({dict(self._params)!r})'

    def get(self, name: str) -> Any:
        """Return the parameters of effect ``name``, or its kind's default when absent."""
        return self[name] if name in self else BY_NAME[name].default()

    @property
    def names(self) -> tuple[str, ...]:
        """Return the names of the effects present, in schema order."""
        return tuple(k for k, _ in self._params)

    @property
    def innovation_corr(self) -> float:
        """Return the innovations' correlation (0 without cross_axis_coupling)."""
        return float(self.get('cross_axis_coupling'))

    @property
    def lag_s(self) -> float:
        """Return the motion lag, s (0 without one)."""
        return float(self.get('motion_lag'))

    @property
    def dof(self) -> float:
        """Return the innovations' degrees of freedom (infinite: Gaussian)."""
        return float(self.get('heavy_tails'))

    @property
    def scales(self) -> tuple[float, ...]:
        """Return the regimes' scales; one scale of 1 without variance_regimes."""
        regimes: Optional[Regimes] = self.get('variance_regimes')
        return (1.0,) if regimes is None else regimes.scales

    @property
    def transition(self) -> tuple[tuple[float, ...], ...]:
        """Return the regimes' transition matrix (((1.0,),) without variance_regimes)."""
        regimes: Optional[Regimes] = self.get('variance_regimes')
        return ((1.0,),) if regimes is None else regimes.transition

    @property
    def street(self) -> Optional[Street]:
        """Return (sigma_along, sigma_across), m, or None."""
        street: Optional[Street] = self.get('street_frame')
        return street

    @property
    def periodic(self) -> Optional[Periodic]:
        """Return the cycle, or None."""
        periodic: Optional[Periodic] = self.get('periodic')
        return periodic

    @property
    def outliers(self) -> Optional[Outliers]:
        """Return the jumps' law, or None."""
        outliers: Optional[Outliers] = self.get('outliers')
        return outliers

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
        return {kind.name: kind.to_dict(params) for kind, params in self}


def effects_from_dict(raw: Any, source: str = '<profile>') -> Effects:
    """Validate a profile's ``effects`` mapping; return :class:`Effects`."""
    if raw is None:
        return Effects()
    if not isinstance(raw, dict):
        raise EffectsError(f'{source}: key \'effects\': expected a mapping, '
                           f'got {raw!r}')
    params: dict[str, Any] = {}
    for name, body in raw.items():
        kind = BY_NAME.get(name)
        if kind is None:
            raise EffectsError(f'{source}: key {"effects." + str(name)!r}: unknown effect; '
                               f'expected one of {list(EFFECT_NAMES)}')
        params[name] = kind.parse(Section(body, source, kind.spec))
    setting = [n for n in params if BY_NAME[n].sets_innovations]
    if setting and params.get('cross_axis_coupling'):
        setting.append('cross_axis_coupling')
    if len(setting) > 1:
        raise EffectsError(f'{source}: key \'effects\': {" and ".join(setting)} both set '
                           f'the innovation covariance; expected one of them')
    return Effects(params)
