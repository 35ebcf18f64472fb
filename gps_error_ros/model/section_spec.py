"""
A profile section declared once: its fields, from which it is read, written and documented.

A :class:`SectionSpec` lists a section's :class:`Field` s, as the nodes'
``ParamSpec`` lists their parameters. :meth:`SectionSpec.read` checks a
mapping against it (the keys, then each value) with errors that name the
key, what was expected and what was given; :meth:`SectionSpec.write` is the
section as plain data (each value rounded as declared); :meth:`SectionSpec.markdown`
is its table in the docs. What one field cannot say (a rule between two
fields) stays with the section's reader.
"""

from collections.abc import Mapping
from dataclasses import dataclass
import math
from typing import Any, Literal, Optional

Kind = Literal['number', 'integer', 'choice', 'pair', 'pairs', 'numbers', 'sizes',
               'distribution', 'by_speed', 'rows']


def _shown(v: float) -> str:
    """Return a bound as people write it: 0.5, 10000, 1e9."""
    return f'{v:g}'.replace('e+0', 'e').replace('e+', 'e').replace('e-0', 'e-')


@dataclass(frozen=True)
class Field:
    """
    One key of a section: its kind, range and meaning.

    ``number``: a finite number in ``lo .. hi`` (``lo_open``, ``hi_open``:
    the bound excluded); ``integer``: an integer in ``[lo, hi]``; ``choice``:
    one of ``choices``; ``pair``: two numbers (north, east) in ``[lo, hi]``;
    ``pairs``: a non-empty list of such pairs;
    ``numbers``: a non-empty list of numbers in ``lo .. hi``; ``sizes``: a
    non-empty, non-decreasing list of numbers in ``lo .. hi``;
    ``distribution``: a non-empty list of [value, probability] pairs, each
    value an integer in ``[lo, hi]`` and each probability in (0, 1].
    ``by_speed``: a table of 1 to ``most`` [speed m/s, value] pairs, speeds
    in [0, 100] increasing, each value in ``lo .. hi``. ``rows``: a
    non-empty list of non-empty lists of numbers in ``lo .. hi`` (a matrix;
    its shape is the section's rule).
    ``absent``: what leaving an optional key out means (None: required).
    ``digits``: the decimals it is written with (None: as it is).
    """

    name: str
    doc: str
    kind: Kind = 'number'
    lo: float = 0.0
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple[str, ...] = ()
    absent: Optional[str] = None
    digits: Optional[int] = None
    most: int = 32

    def expected(self) -> str:
        """Return what the field takes, in words (the errors' and the docs' text)."""
        left, right = '(' if self.lo_open else '[', ')' if self.hi_open else ']'
        span = f'{left}{_shown(self.lo)}, {_shown(self.hi)}{right}'
        if math.isinf(self.lo) and math.isinf(self.hi):
            return {'number': 'a finite number',
                    'numbers': 'a non-empty list of finite numbers'}[self.kind]
        return {'number': f'a number in {span}',
                'integer': f'an integer in {span}',
                'choice': f'one of {list(self.choices)}',
                'pair': f'two numbers (north, east) in {span}',
                'pairs': f'a non-empty list of [north, east] pairs of numbers in {span}',
                'numbers': f'a non-empty list of numbers in {span}',
                'sizes': f'a non-empty, non-decreasing list of numbers in {span}',
                'distribution': f'a non-empty list of [value, probability] pairs (integer '
                                f'values in {span}, probabilities in (0, 1])',
                'by_speed': f'a list of 1 to {self.most} [speed m/s, value] pairs, speeds in '
                            f'[0, 100] increasing, values in {span}',
                'rows': f'a non-empty list of rows, each a non-empty list of numbers in '
                        f'{span}'}[self.kind]

    def _inside(self, v: Any) -> bool:
        """Return True when ``v`` is a number within the field's range."""
        return (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                and (v > self.lo if self.lo_open else v >= self.lo)
                and (v < self.hi if self.hi_open else v <= self.hi))

    def read(self, v: Any) -> Any:
        """Return the value checked (floats as floats, lists as tuples), or None when invalid."""
        if self.kind == 'choice':
            return v if v in self.choices else None
        if self.kind == 'integer':
            ok = isinstance(v, int) and not isinstance(v, bool) and self._inside(v)
            return int(v) if ok else None
        if self.kind == 'number':
            return float(v) if self._inside(v) else None
        if self.kind == 'distribution':
            return self._pairs(v)
        if self.kind == 'by_speed':
            return self._table(v)
        if self.kind == 'rows':
            ok = isinstance(v, list) and bool(v) and all(
                isinstance(r, list) and bool(r) and all(map(self._inside, r)) for r in v)
            return tuple(tuple(float(x) for x in r) for r in v) if ok else None
        if self.kind == 'pairs':
            ok = isinstance(v, list) and bool(v) and all(
                isinstance(p, list) and len(p) == 2 and all(map(self._inside, p)) for p in v)
            return tuple((float(p[0]), float(p[1])) for p in v) if ok else None
        if not isinstance(v, list) or not v or not all(self._inside(x) for x in v):
            return None
        if self.kind == 'pair':
            return tuple(float(x) for x in v) if len(v) == 2 else None
        if self.kind == 'numbers':
            return tuple(float(x) for x in v)
        return tuple(float(x) for x in v) if all(b >= a for a, b in zip(v, v[1:])) else None

    def _table(self, v: Any) -> Optional[tuple[tuple[float, float], ...]]:
        """Return a speed table's (speed, value) pairs checked, or None when invalid."""
        speed = Field('speed', '', lo=0.0, hi=100.0)
        if not isinstance(v, list) or not 1 <= len(v) <= self.most or not all(
                isinstance(p, list) and len(p) == 2 and speed._inside(p[0])
                and self._inside(p[1]) for p in v):
            return None
        if any(b[0] <= a[0] for a, b in zip(v, v[1:])):
            return None
        return tuple((float(p[0]), float(p[1])) for p in v)

    def _pairs(self, v: Any) -> Optional[tuple[tuple[int, float], ...]]:
        """Return a distribution's (value, probability) pairs checked, or None when invalid."""
        def one(p: Any) -> bool:
            return (isinstance(p, list) and len(p) == 2 and isinstance(p[0], int)
                    and self._inside(p[0]) and isinstance(p[1], (int, float))
                    and not isinstance(p[1], bool) and math.isfinite(p[1]) and 0 < p[1] <= 1)
        if not isinstance(v, list) or not v or not all(one(p) for p in v):
            return None
        return tuple((int(p[0]), float(p[1])) for p in v)

    def write(self, v: Any) -> Any:
        """Return a value as the section writes it."""
        if self.kind == 'distribution':
            return [[int(n), self._rounded(p)] for n, p in v]
        if self.kind in ('pairs', 'by_speed', 'rows'):
            return [[self._rounded(x) for x in r] for r in v]
        if self.kind in ('pair', 'numbers', 'sizes'):
            return [self._rounded(x) for x in v]
        if self.kind == 'integer':
            return int(v)
        if self.kind == 'choice':
            return v
        return self._rounded(v)

    def _rounded(self, x: Any) -> float:
        """Return ``x`` as a float with the declared decimals."""
        return round(float(x), self.digits) if self.digits is not None else float(x)


@dataclass(frozen=True)
class SectionSpec:
    """A section of a profile: its key, its fields and the error it raises."""

    key: str
    fields: tuple[Field, ...]
    error: type[ValueError]

    @property
    def required(self) -> list[str]:
        """Return the keys the section must have."""
        return [f.name for f in self.fields if f.absent is None]

    @property
    def optional(self) -> list[str]:
        """Return the keys it may leave out."""
        return [f.name for f in self.fields if f.absent is not None]

    def read(self, raw: Any, source: str) -> dict[str, Any]:
        """
        Return the section's values by field name (None for an optional key left out).

        Raises the section's error naming ``source``, the key and what was
        expected.
        """
        want = (f'exactly {self.required}' if not self.optional else
                f'{self.required} and optionally {self.optional}')
        if not isinstance(raw, Mapping):
            raise self.error(f'{source}: key {self.key!r}: expected a mapping with {want}, '
                             f'got {raw!r}')
        unknown = [k for k in raw if k not in self.required + self.optional]
        missing = [k for k in self.required if k not in raw]
        if unknown or missing:
            what = (f'{self.key}.{unknown[0]} is not a key of it' if unknown else
                    f'{self.key}.{missing[0]} is missing')
            raise self.error(f'{source}: key {self.key!r}: expected a mapping with {want} '
                             f'({what}), got {raw!r}')
        out: dict[str, Any] = {}
        for f in self.fields:
            if f.name not in raw:
                out[f.name] = None
                continue
            value = f.read(raw[f.name])
            if value is None:
                left_out = '' if f.absent is None else f', or the key left out ({f.absent})'
                raise self.error(f'{source}: key {self.key}.{f.name}: expected '
                                 f'{f.expected()}{left_out}, got {raw[f.name]!r}')
            out[f.name] = value
        return out

    def write(self, values: Mapping[str, Any]) -> dict[str, Any]:
        """Return the section as plain data: every field with a value, in declared order."""
        return {f.name: f.write(values[f.name]) for f in self.fields
                if values.get(f.name) is not None}

    def markdown(self) -> str:
        """Return the section's table for the docs: key, what it takes, meaning."""
        lines = ['| key | takes | meaning |', '|---|---|---|']
        for f in self.fields:
            takes = f.expected() + ('' if f.absent is None else f'; left out: {f.absent}')
            lines.append(f'| `{f.name}` | {takes} | {f.doc} |')
        return '\n'.join(lines) + '\n'
