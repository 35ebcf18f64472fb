"""
The state of a crowd of agents, by name: what each model carries from one step to the next.

Every model keeps, for ``n`` agents, a few arrays whose first axis is the
agent. Each model owns a small dataclass that names them (the AR history,
the regime, the heading, an agent's bias, the steps of outage left);
nothing outside the model that owns a field reads or writes it by
position. A wrapper (:mod:`.population`, :mod:`.failures`,
:mod:`.availability`) keeps the state of the model it wraps whole, as its
``inner`` field, beside its own fields: that is the one way a wrapper adds
its part.

What callers do with a state without knowing its fields, this base gives
every state class: :meth:`AgentState.take` (some agents' rows, a copy),
:meth:`AgentState.put` (write rows from another state of the same kind)
and :meth:`AgentState.joined` (append agents), all by walking the fields,
nested states included. A field may be ``None`` (a part the model does not
have, e.g. a population without a held bias), or a tuple of states (a zone
map's processes, :mod:`.zoned`).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Generic, TypeVar

import numpy as np
import numpy.typing as npt

S = TypeVar('S', bound='AgentState')
#: The state class of the model a wrapper wraps.
Inner = TypeVar('Inner', bound='AgentState')

#: A float array (the package's errors, covariances and state fields).
FloatArray = npt.NDArray[np.floating[Any]]
#: An integer array (regimes, phases).
IntArray = npt.NDArray[np.int64]
#: A boolean array (masks: which agents have a fix, which failed).
BoolArray = npt.NDArray[np.bool_]
#: The agents' stream keys: uint64 values, one per agent (:func:`~.streams.agent_keys`).
Keys = Any
#: Numbers in any shape numpy takes: a float, a list, an array (turned into an array inside).
Numbers = Any


@dataclasses.dataclass(eq=False)
class AgentState:
    """Per-agent arrays (agent axis first), walked field by field; see the module docstring."""

    def _items(self) -> list[tuple[str, Any]]:
        return [(f.name, getattr(self, f.name)) for f in dataclasses.fields(self)]

    def __len__(self) -> int:
        """Return the number of agents."""
        for _, value in self._items():
            if isinstance(value, tuple):
                if value:
                    return len(value[0])
            elif value is not None:
                return len(value)
        return 0

    def take(self: S, rows: Any) -> S:
        """Return the state of agents ``rows`` (an index or mask), a copy."""
        out: dict[str, Any] = {}
        for name, value in self._items():
            if value is None:
                out[name] = None
            elif isinstance(value, AgentState):
                out[name] = value.take(rows)
            elif isinstance(value, tuple):
                out[name] = tuple(v.take(rows) for v in value)
            else:
                out[name] = np.array(value[rows])
        return type(self)(**out)

    def copy(self: S) -> S:
        """Return a copy of the whole state."""
        return self.take(slice(None))

    def arrays(self, prefix: str = '') -> dict[str, Any]:
        """Return the arrays of the fields by dotted name (``inner.deviations``), None left out."""
        out: dict[str, Any] = {}
        for name, value in self._items():
            if isinstance(value, AgentState):
                out.update(value.arrays(f'{prefix}{name}.'))
            elif isinstance(value, tuple):
                for i, v in enumerate(value):
                    out.update(v.arrays(f'{prefix}{name}.{i}.'))
            elif value is not None:
                out[prefix + name] = value
        return out

    def same_as(self, other: AgentState) -> bool:
        """Return True when ``other`` is of this class and every field is equal, bit for bit."""
        if type(other) is not type(self):
            return False
        mine, theirs = self.arrays(), other.arrays()
        return mine.keys() == theirs.keys() and all(
            np.array_equal(v, theirs[k], equal_nan=True) for k, v in mine.items())

    def put(self, rows: Any, other: AgentState) -> None:
        """Write ``other``'s agents into rows ``rows`` of this state, in place."""
        if type(other) is not type(self):
            raise TypeError(f'cannot put a {type(other).__name__} into a '
                            f'{type(self).__name__}')
        for name, value in self._items():
            if value is None:
                continue
            if isinstance(value, AgentState):
                value.put(rows, getattr(other, name))
            elif isinstance(value, tuple):
                for mine, theirs in zip(value, getattr(other, name)):
                    mine.put(rows, theirs)
            else:
                value[rows] = getattr(other, name)

    def joined(self: S, other: S) -> S:
        """Return this state with ``other``'s agents appended (a new state)."""
        if type(other) is not type(self):
            raise TypeError(f'cannot join a {type(other).__name__} to a '
                            f'{type(self).__name__}')
        out: dict[str, Any] = {}
        for name, value in self._items():
            if value is None:
                out[name] = None
            elif isinstance(value, AgentState):
                out[name] = value.joined(getattr(other, name))
            elif isinstance(value, tuple):
                out[name] = tuple(a.joined(b) for a, b in zip(value, getattr(other, name)))
            else:
                out[name] = np.concatenate([value, getattr(other, name)])
        return type(self)(**out)


@dataclasses.dataclass(eq=False)
class WrappedState(AgentState, Generic[Inner]):
    """
    The base of a wrapper's state: the wrapped model's state, whole, as ``inner``.

    A wrapper's own fields follow it in its subclass (:mod:`.population`,
    :mod:`.failures`, :mod:`.availability`); ``Inner`` is the wrapped model's
    state class, so a wrapper's state is typed to the end.
    """

    inner: Inner


@dataclasses.dataclass(eq=False)
class ARState(AgentState):
    """
    The AR process's state: its last ``p`` deviations from the mean.

    ``deviations`` (n, 2, p): ``[:, a, 0]`` axis ``a``'s current deviation
    (north 0, east 1), ``[:, a, i]`` the one ``i`` steps ago.
    """

    deviations: FloatArray


@dataclasses.dataclass(eq=False)
class EffectsState(AgentState):
    """
    The state of the AR process with effects (:class:`~.effects.ExtendedModel`).

    Attributes
    ----------
    deviations : (n, 2, p) float
        The AR deviations, as :class:`ARState`'s (a cycle's mean included).
    regime : (n,) int
        The current variance regime's index (0 without regimes).
    heading : (n,) float
        The direction of travel, radians from north, clockwise
        (street_frame; 0 until one is known).
    phase : (n,) int
        The current step's phase in the cycle (periodic).
    cycle_offset : (n,) int
        The agent's offset in the cycle (periodic).
    jump : (n, 2) float
        The jump's (north, east) offset, metres (outliers).
    in_jump : (n,) float
        1.0 while a jump lasts, else 0.0 (outliers).

    """

    deviations: FloatArray
    regime: IntArray
    heading: FloatArray
    phase: IntArray
    cycle_offset: IntArray
    jump: FloatArray
    in_jump: FloatArray


def zeros_effects_state(n: int, order: int) -> EffectsState:
    """Return an :class:`EffectsState` of ``n`` agents, all zeros."""
    return EffectsState(np.zeros((n, 2, order)), np.zeros(n, dtype=np.int64), np.zeros(n),
                        np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64),
                        np.zeros((n, 2)), np.zeros(n))
