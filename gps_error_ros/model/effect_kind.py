"""
What an effect is: its section of a profile, and its part in the model's step.

Every effect of a profile's ``effects`` section is one :class:`EffectKind`
in a module of :mod:`gps_error_ros.model.effect_kinds` (the registry finds
it there). The kind reads and writes its YAML section and says what it is
for the docs; :meth:`EffectKind.term` binds its parameters to a model as a
:class:`Term`, the effect's part in :class:`~.effects.ExtendedModel`'s step.
A term overrides only the hooks its effect needs; the model calls each hook
on the terms that override it, in the kinds' ``stage`` order.

The step of one model step ``k``, as the hooks enter it::

    w = innovations (a term's, else the AR part's own, Gaussian)
    w = shape(w) for each term              (regimes, tails, the cycle)
    u = w + sum_i phi_i u(k - i)            (the AR part)
    e = output(u + delta) for each term     (a jump's offset)

and the moments beside it: the variance factor of the innovations, the
autocovariance a term adds, the next step's covariance and mean given the
state.
"""

from typing import Any, ClassVar, Generic, Optional, TypeVar

import numpy as np

from gps_error_ros.model.ar_model import AxisParams
from gps_error_ros.model.section_spec import Field, SectionSpec
from gps_error_ros.model.state import EffectsState, FloatArray, Keys

P = TypeVar('P')


class EffectsError(ValueError):
    """An ``effects`` section that does not match the schema."""


class Section:
    """
    One effect's mapping under ``effects``, read through its declared fields.

    Each value is checked against its :class:`~.section_spec.Field` (the
    errors name the key, what was expected and what was given); what no
    one field can say (a matrix's shape, rows summing to 1) is the kind's
    :meth:`EffectKind.parse`, which raises :meth:`fail`.
    """

    def __init__(self, body: Any, source: str, spec: SectionSpec) -> None:
        self.key = spec.key
        self.source = source
        self.values = spec.read(body, source)
        self.body = body

    def number(self, key: str) -> float:
        """Return the number at ``key``, checked."""
        return float(self.values[key])

    def table(self, key: str) -> Any:
        """Return the list (as tuples) at ``key``, checked."""
        return self.values[key]

    def fail(self, what: str) -> EffectsError:
        """Return the error for this section: ``what`` was wrong."""
        return EffectsError(f'{self.source}: key {self.key}{what}')


class Term:
    """
    An effect's part in the step of an :class:`~.effects.ExtendedModel`.

    Every hook's default does nothing; :attr:`HOOKS` names those the model
    calls only on the terms that override them.
    """

    HOOKS: ClassVar[tuple[str, ...]] = (
        'innovations', 'innovation_cov', 'shape', 'output', 'current', 'initial', 'resume',
        'autocovariance', 'step_factor', 'added_cov', 'mean_term')
    #: the factor of the innovations' variance, averaged over the effect's own law
    variance_factor: float = 1.0

    def innovations(self, state: EffectsState, z: FloatArray) -> FloatArray:
        """Return the innovations, (n, 2), from standard normal pairs ``z`` (one term may)."""
        raise NotImplementedError

    def innovation_cov(self, state: EffectsState) -> FloatArray:
        """Return each agent's innovation covariance (n, 2, 2) (the term of ``innovations``)."""
        raise NotImplementedError

    def shape(self, state: EffectsState, keys: Keys, index: int, w: FloatArray) -> FloatArray:
        """Return the innovations ``w`` (n, 2) of step ``index`` as this effect shapes them."""
        return w

    def output(self, state: EffectsState, keys: Keys, index: int,
               errors: FloatArray) -> FloatArray:
        """Advance what the effect adds outside the AR part; return ``errors`` with it."""
        return errors

    def current(self, state: EffectsState, errors: FloatArray) -> FloatArray:
        """Return ``errors`` with what the effect adds now (no step taken)."""
        return errors

    def initial(self, state: EffectsState, keys: Keys, index: int) -> None:
        """Draw the effect's state of a run starting at ``index`` (AR part already drawn)."""

    def resume(self, state: EffectsState, keys: Keys, index: int) -> None:
        """Draw the effect's state of agents entering at ``index`` with their AR errors."""
        self.initial(state, keys, index)

    def autocovariance(self, max_lag: int) -> FloatArray:
        """Return what the effect adds to the AR part's autocovariance, (max_lag + 1, 2, 2)."""
        return np.zeros((max_lag + 1, 2, 2))

    def step_factor(self, state: EffectsState) -> FloatArray:
        """Return the factor (n,) of the next innovation's variance given ``state``."""
        return np.ones(len(state))

    def added_cov(self, state: EffectsState, first: bool) -> FloatArray:
        """Return the covariance (n, 2, 2) the effect adds to the next error's."""
        return np.zeros((len(state), 2, 2))

    def mean_term(self, state: EffectsState) -> FloatArray:
        """Return what the effect adds (n, 2) to the next error's expectation."""
        return np.zeros((len(state), 2))


class EffectKind(Generic[P]):
    """
    One effect: its YAML section, its line in the docs, and its term in the step.

    A module of :mod:`gps_error_ros.model.effect_kinds` defines ``KIND``, an
    instance of a subclass. ``order`` places it in the schema (a profile's
    ``effects`` are written in that order), ``stage`` in the step.
    """

    name: ClassVar[str]
    #: its YAML section, key by key: read, written and documented from these
    fields: ClassVar[tuple[Field, ...]]
    summary: ClassVar[str]
    order: ClassVar[int]
    stage: ClassVar[int] = 0
    #: True when the effect's step needs the direction of travel
    needs_heading: ClassVar[bool] = False
    #: True when the effect sets the innovation covariance (one such effect per profile)
    sets_innovations: ClassVar[bool] = False

    @property
    def keys(self) -> tuple[str, ...]:
        """Return the section's keys."""
        return tuple(f.name for f in self.fields)

    @property
    def spec(self) -> SectionSpec:
        """Return the section as a :class:`~.section_spec.SectionSpec` (``effects.<name>``)."""
        return SectionSpec(f'effects.{self.name}', self.fields, EffectsError)

    def parse(self, section: Section) -> P:
        """Return the effect's parameters from its checked section."""
        raise NotImplementedError

    def to_dict(self, params: P) -> dict[str, Any]:
        """Return the effect's section as plain data."""
        raise NotImplementedError

    def ar(self, params: P, north: AxisParams, east: AxisParams,
           corr: float) -> tuple[AxisParams, AxisParams, float]:
        """Return the AR part's axes and innovation correlation under this effect."""
        return north, east, corr

    def term(self, params: P, phi: FloatArray, order: int) -> Optional[Term]:
        """Return the effect's term in a step with AR coefficients ``phi`` (None: no term)."""
        return None

    def absent(self, params: P) -> bool:
        """Return True when ``params`` mean the effect is not there (a zero lag, say)."""
        return False

    def default(self) -> Any:
        """Return what the legacy accessor of :class:`~.effect_schema.Effects` gives without it."""
        return None


class OneNumber(EffectKind[float]):
    """An effect whose parameters are one number, its one field; ``none`` means it is absent."""

    #: the value that means no effect (what the accessors give without it)
    none: ClassVar[float]

    def parse(self, section: Section) -> float:
        """Return the number, in its range."""
        return section.number(self.fields[0].name)

    def to_dict(self, params: float) -> dict[str, Any]:
        """Return the section."""
        return self.spec.write({self.fields[0].name: params})

    def absent(self, params: float) -> bool:
        """Return True for the value that means no effect."""
        return params == self.none

    def default(self) -> float:
        """Return the value that means no effect."""
        return self.none
