"""
The registry of effects: every module here defines ``KIND``, one :class:`~.effect_kind.EffectKind`.

The schema (:mod:`~.effect_schema`), the model's step
(:class:`~.effects.ExtendedModel`), zones, the diagnosis's list of effects
and the docs' table of effects all read :data:`KINDS`. A new effect is a new
module here (see ``docs/architecture.md``, "A new effect").
"""

import importlib
import pkgutil
from typing import Any

from gps_error_ros.model.effect_kind import EffectKind


def _found() -> tuple[EffectKind[Any], ...]:
    """Return the ``KIND`` of every module of this package, in schema order."""
    kinds = [importlib.import_module(f'{__name__}.{m.name}').KIND
             for m in pkgutil.iter_modules(__path__)]
    kinds.sort(key=lambda k: (k.order, k.name))
    names = [k.name for k in kinds]
    if len(set(names)) != len(names):
        raise RuntimeError(f'effect kinds: a name twice in {names}')
    return tuple(kinds)


#: Every effect, in schema order (the order a profile's ``effects`` are written in).
KINDS: tuple[EffectKind[Any], ...] = _found()
#: Their names, in schema order.
EFFECT_NAMES: tuple[str, ...] = tuple(k.name for k in KINDS)
BY_NAME: dict[str, EffectKind[Any]] = {k.name: k for k in KINDS}


def markdown_table() -> str:
    """Return the docs' table of effects (``docs/effects.md``), one row per kind."""
    lines = ['| effect | keys | what it does | step needs the heading |', '|---|---|---|---|']
    for k in KINDS:
        keys = ', '.join(f'`{key}`' for key in k.keys)
        lines.append(f'| `{k.name}` | {keys} | {k.summary} | '
                     f'{"yes" if k.needs_heading else "no"} |')
    return '\n'.join(lines) + '\n'


def keys_table() -> str:
    """Return the docs' table of every effect's keys: what each takes, from its fields."""
    lines = ['| key | takes | meaning |', '|---|---|---|']
    for k in KINDS:
        for f in k.fields:
            lines.append(f'| `{k.name}.{f.name}` | {f.expected()} | {f.doc} |')
    return '\n'.join(lines) + '\n'
