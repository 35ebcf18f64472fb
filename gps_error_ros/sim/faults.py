"""
Faults on demand: a chosen fault on a chosen agent at a chosen time.

A fault schedule (a YAML file, or the error node's ``faults`` parameter at
run time) lists faults, each with a kind, a start ``at`` (seconds of the
clock that stamps the fixes: ROS time in the node, the trajectory's ``t`` in
``gps_error simulate``), a ``duration`` (seconds) and an ``agent`` (a name;
omitted or ``'*'``: every agent)::

    faults:
      - {kind: outage, at: 30, duration: 10, agent: walker_1}
      - {kind: frozen, at: 60, duration: 20}
      - {kind: offset, at: 90, duration: 5, size_m: 25, bearing_deg: 90}
      - {kind: degraded, at: 120, duration: 30, scale: 3}
      - {kind: gross_failure, at: 150, size_m: 2500, bearing_deg: 200}

A fault covers the fixes stamped from ``at`` (included) to ``at +
duration`` (excluded). The kinds:

* ``outage``: no fix (published as the node's ``outage_output`` says:
  NO_FIX, or nothing).
* ``frozen``: the receiver stops updating: the fault's first fix is
  published as usual, and every later fix of the fault repeats its position
  (and its velocity). The stamp goes on. The stated covariance grows from
  the first fix's by ``(growth_mps * age)^2`` per axis, ``age`` the seconds
  since that fix (``growth_mps`` default 1.5 m/s, a walking speed).
* ``offset``: the fix moves by ``size_m`` towards ``bearing_deg`` (degrees
  from north, clockwise) for the duration, then back. The stated
  covariance is unchanged (the receiver does not know).
* ``degraded``: the error about the truth is multiplied by ``scale``, and
  the stated covariance by ``scale^2`` (a receiver knows when its signals
  are poor).
* ``gross_failure``: one fix ``size_m`` (default 2,500 m) towards
  ``bearing_deg``: the first fix of each agent in the window (``duration``
  default 1 s). The stated covariance is unchanged.

Faults sit on top of the error stream: the model goes on underneath, so
the fixes after a fault are those the run would have had without it. Where
faults overlap on a fix they apply in the order degraded, offset,
gross_failure, frozen, outage (an outage wins). The reasons for the stated
covariances are in ``docs/decisions/0034-faults-on-demand.md``.
"""

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
import math
import os
from typing import Any

import numpy as np
import yaml

from gps_error_ros.model.geodesy import difference, offset
from gps_error_ros.model.state import BoolArray, FloatArray, IntArray
from gps_error_ros.model.streams import agent_key, agent_keys

NS = 1_000_000_000
#: The kinds of fault, in the order they apply to one fix.
FAULT_KINDS = ('degraded', 'offset', 'gross_failure', 'frozen', 'outage')
#: A frozen fix's stated SD grows this fast by default (m/s): a walking speed.
FROZEN_GROWTH_MPS = 1.5
#: A gross failure's distance from the truth by default (m).
GROSS_SIZE_M = 2500.0
#: A gross failure's window by default (s): its first fix in it is off.
GROSS_WINDOW_S = 1.0
ALL_AGENTS = '*'

_COMMON = ('kind', 'at', 'duration', 'agent')
_FIELDS = {
    'outage': _COMMON,
    'frozen': _COMMON + ('growth_mps',),
    'offset': _COMMON + ('size_m', 'bearing_deg'),
    'degraded': _COMMON + ('scale',),
    'gross_failure': _COMMON + ('size_m', 'bearing_deg'),
}
_REQUIRED = {
    'outage': ('at', 'duration'),
    'frozen': ('at', 'duration'),
    'offset': ('at', 'duration', 'size_m'),
    'degraded': ('at', 'duration', 'scale'),
    'gross_failure': ('at',),
}


class FaultError(ValueError):
    """A fault or schedule that is not valid: says which and what was expected."""


@dataclass(frozen=True)
class Fault:
    """One fault (see the module doc); times in ns of the fixes' clock."""

    kind: str
    at_ns: int
    duration_ns: int
    agent: str | None = None        # None: every agent
    size_m: float = 0.0
    bearing_deg: float = 0.0
    scale: float = 1.0
    growth_mps: float = FROZEN_GROWTH_MPS

    @property
    def end_ns(self) -> int:
        """Return the first instant after the fault (ns)."""
        return self.at_ns + self.duration_ns

    @property
    def shift(self) -> FloatArray:
        """Return the (north, east) metres of an offset or gross failure."""
        b = math.radians(self.bearing_deg)
        return np.array([self.size_m * math.cos(b), self.size_m * math.sin(b)])

    def to_dict(self) -> dict[str, Any]:
        """Return the fault as a schedule entry (seconds)."""
        out: dict[str, Any] = {'kind': self.kind, 'at': self.at_ns / NS,
                               'duration': self.duration_ns / NS,
                               'agent': ALL_AGENTS if self.agent is None else self.agent}
        extra = {'frozen': ('growth_mps',), 'offset': ('size_m', 'bearing_deg'),
                 'degraded': ('scale',), 'gross_failure': ('size_m', 'bearing_deg')}
        for name in extra.get(self.kind, ()):
            out[name] = getattr(self, name)
        return out


def _number(where: str, name: str, value: Any, low: float | None = None,
            positive: bool = False) -> float:
    """Return ``value`` as a finite float, or raise a FaultError naming it."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or \
            not math.isfinite(value):
        raise FaultError(f'{where}: {name} must be a finite number, got {value!r}')
    if positive and not value > 0:
        raise FaultError(f'{where}: {name} must be > 0, got {value!r}')
    if low is not None and value < low:
        raise FaultError(f'{where}: {name} must be >= {low:g}, got {value!r}')
    return float(value)


def fault_from_dict(raw: Any, where: str = 'fault', now_s: float | None = None) -> Fault:
    """
    Return the fault of one schedule entry, or raise a :class:`FaultError` naming what is wrong.

    ``now_s``: an entry without ``at`` starts then (the node's runtime
    parameter); None: ``at`` is required.
    """
    if not isinstance(raw, Mapping):
        raise FaultError(f'{where}: expected a mapping such as {{kind: outage, at: 30, '
                         f'duration: 10}}, got {raw!r}')
    kind = raw.get('kind')
    if kind not in _FIELDS:
        raise FaultError(f'{where}: kind must be one of {", ".join(sorted(_FIELDS))}, '
                         f'got {kind!r}')
    unknown = sorted(set(map(str, raw)) - set(_FIELDS[kind]))
    if unknown:
        raise FaultError(f'{where}: {kind} takes {", ".join(_FIELDS[kind])}; unknown: '
                         f'{", ".join(unknown)}')
    entry = dict(raw)
    if 'at' not in entry and now_s is not None:
        entry['at'] = now_s
    missing = [k for k in _REQUIRED[kind] if k not in entry]
    if missing:
        raise FaultError(f'{where}: {kind} needs {", ".join(missing)}')
    at = _number(where, 'at', entry['at'], low=0.0)
    default = GROSS_WINDOW_S if kind == 'gross_failure' else None
    duration = _number(where, 'duration', entry.get('duration', default), positive=True)
    agent = entry.get('agent', ALL_AGENTS)
    if not isinstance(agent, str):
        raise FaultError(f'{where}: agent must be an agent\'s name or \'*\' (every agent), '
                         f'got {agent!r}')
    size = entry.get('size_m', GROSS_SIZE_M if kind == 'gross_failure' else 0.0)
    return Fault(kind=kind, at_ns=int(round(at * NS)), duration_ns=int(round(duration * NS)),
                 agent=None if agent == ALL_AGENTS else agent,
                 size_m=_number(where, 'size_m', size, low=0.0),
                 bearing_deg=_number(where, 'bearing_deg', entry.get('bearing_deg', 0.0)),
                 scale=_number(where, 'scale', entry.get('scale', 1.0), positive=True),
                 growth_mps=_number(where, 'growth_mps',
                                    entry.get('growth_mps', FROZEN_GROWTH_MPS), low=0.0))


def faults_from_yaml(text: str, source: str = 'faults', now_s: float | None = None
                     ) -> list[Fault]:
    """
    Return the faults of YAML ``text``: ``{faults: [...]}``, a list, or one entry.

    Raises a :class:`FaultError` naming ``source`` and the entry at fault.
    """
    try:
        raw = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise FaultError(f'{source}: not YAML: {exc}') from None
    if isinstance(raw, Mapping) and 'faults' in raw:
        if set(raw) != {'faults'}:
            raise FaultError(f'{source}: expected only a \'faults\' list at the top, '
                             f'got {sorted(map(str, raw))}')
        raw = raw['faults']
    if isinstance(raw, Mapping):
        raw = [raw]
    if not isinstance(raw, list):
        raise FaultError(f'{source}: expected a list of faults (or {{faults: [...]}}), '
                         f'got {raw!r}')
    return [fault_from_dict(entry, f'{source}: fault {i + 1}', now_s)
            for i, entry in enumerate(raw)]


def load_schedule(path: str | os.PathLike[str]) -> list[Fault]:
    """Return the faults of a schedule file (YAML; see the module doc)."""
    try:
        with open(path, encoding='utf-8') as f:
            text = f.read()
    except OSError as exc:
        raise FaultError(f'fault schedule {path}: cannot read it: {exc.strerror}') from None
    return faults_from_yaml(text, f'fault schedule {path}')


@dataclass
class FixRows:
    """
    The fixes of one stamp, as the faults see them (arrays over rows).

    ``error`` is about ``truth`` (the position the error was added to), so
    ``lat, lon = offset(truth, error)``; ``extra`` holds per-row values a
    frozen receiver repeats (its velocity, say), first axis the rows.
    """

    stamp_ns: int
    ids: IntArray               # stable per-agent row ids of the caller (memory of frozen)
    keys: np.ndarray            # the agents' stream keys
    truth_lat: FloatArray
    truth_lon: FloatArray
    lat: FloatArray
    lon: FloatArray
    alt: FloatArray
    error: FloatArray           # (m, 2) north/east m
    fix: BoolArray
    cov: FloatArray             # (m, 2, 2) north/east m^2
    extra: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass
class _Held:
    """A frozen receiver's fix: what it repeats."""

    stamp_ns: int
    fix: bool
    lat: float
    lon: float
    alt: float
    cov: FloatArray
    extra: dict[str, np.ndarray]


class FaultOverlay:
    """
    Apply a schedule's faults to fixes as they are made (see the module doc).

    ``seed`` names the agents' streams (an agent in a fault is matched by its
    stream key). Each caller gives its rows stable ``ids``: a frozen
    receiver's held fix is kept per (fault, id); :meth:`forget` drops an id
    whose agent left.
    """

    def __init__(self, faults: Iterable[Fault], seed: int) -> None:
        self.seed = seed
        self.faults: list[Fault] = []
        self._keys: list[np.uint64 | None] = []
        self._held: list[dict[int, _Held]] = []
        self._fired: list[set[int]] = []
        self.applied = dict.fromkeys(FAULT_KINDS, 0)     # fixes touched, per kind
        self._names: dict[str, int] = {}                 # ids_of: agent name -> row id
        self.add(faults)

    def add(self, faults: Iterable[Fault]) -> None:
        """Add faults to the schedule (at run time too)."""
        for f in faults:
            self.faults.append(f)
            self._keys.append(None if f.agent is None else agent_key(self.seed, f.agent))
            self._held.append({})
            self._fired.append(set())

    def ids_of(self, names: Sequence[str]) -> IntArray:
        """Return stable row ids of the agents ``names``, for callers that name their agents."""
        return np.array([self._names.setdefault(n, len(self._names)) for n in names],
                        dtype=np.int64)

    def forget(self, ids: Iterable[int]) -> None:
        """Drop what is held for ``ids`` (their agents left; the ids may be reused)."""
        gone = set(int(i) for i in ids)
        for held, fired in zip(self._held, self._fired):
            for i in gone:
                held.pop(i, None)
            fired -= gone

    def active_at(self, stamp_ns: int) -> list[int]:
        """Return the indices of the faults covering ``stamp_ns``, in their order of kinds."""
        on = [i for i, f in enumerate(self.faults) if f.at_ns <= stamp_ns < f.end_ns]
        return sorted(on, key=lambda i: FAULT_KINDS.index(self.faults[i].kind))

    def apply(self, rows: FixRows) -> BoolArray:
        """
        Apply the faults covering ``rows.stamp_ns`` to ``rows`` in place.

        Returns the rows touched (their error, position, fix, covariance or
        extra values may have changed; the others are as they came).
        """
        touched = np.zeros(rows.ids.size, dtype=bool)
        for i in self.active_at(rows.stamp_ns):
            fault, key = self.faults[i], self._keys[i]
            mine = np.ones(rows.ids.size, dtype=bool) if key is None else rows.keys == key
            if not mine.any():
                continue
            sel = np.flatnonzero(mine)
            if fault.kind == 'gross_failure':
                sel = np.array([j for j in sel if int(rows.ids[j]) not in self._fired[i]],
                               dtype=np.int64)
                self._fired[i].update(int(rows.ids[j]) for j in sel)
                if not sel.size:
                    continue
            getattr(self, '_' + fault.kind)(i, fault, rows, sel)
            self.applied[fault.kind] += int(sel.size)
            touched[sel] = True
        return touched

    def _move(self, rows: FixRows, sel: IntArray) -> None:
        """Place rows ``sel`` at their truth plus their (changed) error."""
        lat, lon = offset(rows.truth_lat[sel], rows.truth_lon[sel], rows.error[sel, 0],
                          rows.error[sel, 1])
        rows.lat[sel], rows.lon[sel] = lat, lon

    def _degraded(self, i: int, fault: Fault, rows: FixRows, sel: IntArray) -> None:
        rows.error[sel] *= fault.scale
        rows.cov[sel] *= fault.scale ** 2
        self._move(rows, sel)

    def _offset(self, i: int, fault: Fault, rows: FixRows, sel: IntArray) -> None:
        rows.error[sel] += fault.shift
        self._move(rows, sel)

    _gross_failure = _offset

    def _outage(self, i: int, fault: Fault, rows: FixRows, sel: IntArray) -> None:
        rows.fix[sel] = False
        rows.lat[sel] = rows.lon[sel] = np.nan

    def _frozen(self, i: int, fault: Fault, rows: FixRows, sel: IntArray) -> None:
        held = self._held[i]
        for j in sel:
            h = held.get(int(rows.ids[j]))
            if h is None:           # the fault's first fix: published, then held
                held[int(rows.ids[j])] = _Held(
                    rows.stamp_ns, bool(rows.fix[j]), float(rows.lat[j]), float(rows.lon[j]),
                    float(rows.alt[j]), rows.cov[j].copy(),
                    {k: np.array(v[j], copy=True) for k, v in rows.extra.items()})
                continue
            rows.fix[j] = h.fix
            rows.lat[j], rows.lon[j], rows.alt[j] = h.lat, h.lon, h.alt
            age = (rows.stamp_ns - h.stamp_ns) / NS
            rows.cov[j] = h.cov + (fault.growth_mps * age) ** 2 * np.eye(2)
            for k, v in h.extra.items():
                rows.extra[k][j] = v
        if not sel.size:
            return
        ok = sel[rows.fix[sel]]
        north, east = difference(rows.lat[ok], rows.lon[ok], rows.truth_lat[ok],
                                 rows.truth_lon[ok])
        rows.error[ok, 0], rows.error[ok, 1] = north, east


def lay_over_rows(overlay: FaultOverlay, t: FloatArray, agents: Sequence[str],
                  rows: FixRows) -> BoolArray:
    """
    Lay ``overlay``'s faults over ``rows`` of many times, one time after another, as the node.

    ``t`` (s, non-decreasing) and ``agents`` name each row; a frozen
    receiver repeats the columns ``speed`` and ``bearing`` of ``rows.extra``.
    Returns the rows touched.
    """
    touched = np.zeros(t.size, dtype=bool)
    keep = {'speed', 'bearing'} & set(rows.extra)       # what a frozen receiver repeats
    bounds = np.flatnonzero(np.r_[True, np.diff(t) > 0, True])
    for b0, b1 in zip(bounds[:-1], bounds[1:]):
        names = agents[b0:b1]
        sel = slice(b0, b1)
        block = FixRows(int(round(t[b0] * 1e9)),
                        overlay.ids_of(names),
                        agent_keys(overlay.seed, names), rows.truth_lat[sel],
                        rows.truth_lon[sel], rows.lat[sel], rows.lon[sel], rows.alt[sel],
                        rows.error[sel], rows.fix[sel], rows.cov[sel],
                        {k: rows.extra[k][sel] for k in keep})
        touched[sel] = overlay.apply(block)         # the block's arrays are views: in place
    return touched


def schedule_text(faults: Sequence[Fault]) -> str:
    """Return ``faults`` as a schedule file's YAML."""
    return yaml.safe_dump({'faults': [f.to_dict() for f in faults]}, sort_keys=False)
