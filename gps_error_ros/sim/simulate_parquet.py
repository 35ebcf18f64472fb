"""
``gps_error simulate`` on SUMO's FCD as Parquet: the XML path's errors, column by column.

The file is read a record batch at a time and written as it is read
(:mod:`~gps_error_ros.traces.fcd_parquet`); every timestep goes through
the same :class:`~gps_error_ros.sim.fcd_step.FcdSteps` as the XML path,
so the same seed, profile and file give the same errors in either format,
bit for bit. The output keeps every input column and row. It replaces each
agent's ``<kind>_x`` and ``<kind>_y`` with the noisy position, null in an
outage. It appends ``fix`` (False in an outage; null on a row with no
agent), the stated accuracy (``accuracy``, ``accuracy_major``,
``accuracy_minor``, ``accuracy_orientation``) and, as the profile has
them, ``reported_speed`` and ``reported_bearing``. On a georeferenced
network's metres it also appends the noisy ``lon`` and ``lat``; with
``errors``, the ``error_north`` and ``error_east`` of each position.
"""

from collections.abc import Sequence
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
import os
from typing import Any

import numpy as np

from gps_error_ros.model.atomic import atomic_output, PathArg
from gps_error_ros.model.protocol import ErrorModel, S
from gps_error_ros.model.state import BoolArray, FloatArray
from gps_error_ros.sim.fcd_step import (FcdColumns, fcd_counts, FcdRequest, FcdSteps,
                                        position_mode)
from gps_error_ros.sim.trajectory_fixes import model_step
from gps_error_ros.traces.fcd_parquet import (Chunk, FcdParquet, pyarrow_modules,
                                              read_ahead, WriteBehind)
from gps_error_ros.traces.progress import Progress
from gps_error_ros.traces.trajectories import TrajectoryError


def parquet_mode(src: PathArg, net: PathArg | None,
                 coordinates: str | None) -> tuple[str, Any]:
    """
    Return how to move a Parquet FCD file's positions (see :func:`position_mode`).

    SUMO's Parquet carries no options, so whether x/y are lon/lat is never
    read from the file: it is ``coordinates``, or lon/lat when no ``net``
    is given and x/y metres when one is.
    """
    if coordinates is None:
        if net is None:
            raise TrajectoryError(
                f'{src}: SUMO\'s Parquet output does not say whether x/y are lon/lat '
                f'or metres: pass --coordinates lonlat (SUMO ran with '
                f'--fcd-output.geo) or --coordinates xy --net NET.xml')
        coordinates = 'xy'
    return position_mode(src, coordinates, net)


def simulate_parquet(src: PathArg, dst: PathArg, request: FcdRequest[S],
                     start_s: float | None = None) -> dict[str, int]:
    """
    Add errors to every agent of a Parquet FCD file; return counts (see module doc).

    ``request``: the model and the options (those of
    :func:`~gps_error_ros.sim.simulate.simulate_fcd`). ``start_s``: the
    time the run starts at (default: the first row with an agent); a part
    of a file split by agent is given the whole file's, so its agents get
    the errors of the whole run. A malformed or truncated file is refused,
    naming it, and leaves no output.
    """
    mode, proj = parquet_mode(src, request.net, request.coordinates)
    fcd = FcdParquet(src)
    start = None if start_s is None else model_step(start_s, request.rate_hz)
    steps = FcdSteps(src, request.model, request.options(mode, proj), start_step=start)
    with atomic_output(dst) as tmp:
        return _run(fcd, steps, tmp, request.model, request.errors, bool(request.faults))


def _run(fcd: FcdParquet, steps: FcdSteps[S], dst: PathArg, model: ErrorModel[S],
         errors: bool, faults: bool) -> dict[str, int]:
    """
    Stream ``fcd`` through ``steps`` into ``dst``; return counts.

    The model steps each chunk here, in order; moving its positions and
    building its table (pyproj and Arrow, without the interpreter's lock)
    run in a pool beside it, a few chunks behind, and are written in order.
    """
    progress = Progress(fcd.rows, f'simulating {fcd.path}', min_total=1 << 20)
    writer = WriteBehind(dst)
    timesteps, rows, no_fix = 0, 0, 0
    seen: set[str] = set()
    last = None
    pending: deque[Future[Any]] = deque()
    try:
        with ThreadPoolExecutor(_CORES, thread_name_prefix='fcd-move') as pool:
            for chunk in read_ahead(fcd.chunks()):
                stepped = _stepped(chunk, steps)
                pending.append(pool.submit(_finished, chunk, fcd.kinds, steps, stepped, errors))
                while len(pending) > _CORES or (pending and pending[0].done()):
                    writer.write(pending.popleft().result())
                counts = stepped.counts
                timesteps += counts[0]
                rows += counts[1]
                no_fix += counts[2]
                if chunk.dictionary is not last:
                    seen.update(chunk.dictionary)
                    last = chunk.dictionary
                progress.update(chunk.t.size)
            while pending:
                writer.write(pending.popleft().result())
    finally:
        writer.close()
        progress.close()
    return fcd_counts(fcd.path, model, timesteps, rows, len(seen), no_fix, faults)


@dataclass
class _Stepped:
    """A chunk's columns from the model; ``moved``: whether x/y are moved yet."""

    cols: dict[str, FloatArray]
    fix: BoolArray
    has: BoolArray
    moved: bool
    counts: tuple[int, int, int]


def _stepped(chunk: Chunk, steps: FcdSteps[S]) -> _Stepped:
    """Return one chunk's columns, stepped through the model timestep by timestep."""
    has = chunk.codes >= 0
    parts: list[tuple[BoolArray, FcdColumns]] = []
    for t, rows in chunk.timesteps():
        sel = has[rows]
        codes = chunk.codes[rows][sel]
        out = steps.timestep(t, chunk.names[rows][sel], chunk.x[rows][sel], chunk.y[rows][sel],
                             (chunk.dictionary, codes), defer=True)
        parts.append((sel, out))
    cols = _gathered(chunk.t.size, has, parts)
    fix = cols.pop('fix').astype(bool)
    got = int(fix[has].sum())
    return _Stepped(cols, fix, has, all(out.moved for _, out in parts),
                    (len(parts), got, int(has.sum()) - got))


def _finished(chunk: Chunk, kinds: Sequence[str], steps: FcdSteps[S], stepped: _Stepped,
              errors: bool) -> Any:
    """Return one stepped chunk's output table, its positions moved."""
    if not stepped.moved:
        _move(steps, chunk.t, stepped.cols, stepped.has)
    return _with_columns(chunk.table, kinds, stepped.cols, stepped.fix, stepped.has, errors)


def _move(steps: FcdSteps[S], t: FloatArray, cols: dict[str, FloatArray], has: BoolArray) -> None:
    """
    Move the chunk's truth (``cols`` x, y) by its errors, in place.

    Each row's doubles are those of its timestep moved alone.
    """
    rows = np.flatnonzero(has)
    err = np.stack([cols['error_north'][rows], cols['error_east'][rows]], axis=1)
    nx, ny, geo = steps.move(t[rows], cols['x'][rows], cols['y'][rows], err)
    cols['x'][rows], cols['y'][rows] = nx, ny
    if geo is not None:
        cols.setdefault('lon', np.full(t.size, np.nan))[rows] = geo[0]
        cols.setdefault('lat', np.full(t.size, np.nan))[rows] = geo[1]


#: Chunks moved and built at once (pyproj and Arrow release the interpreter's lock).
_CORES = os.cpu_count() or 1


def _gathered(n: int, has: BoolArray, parts: Sequence[tuple[BoolArray, FcdColumns]]
              ) -> dict[str, FloatArray]:
    """Return the chunk's columns, each timestep's rows put back in place (NaN: no agent)."""
    first = next((out for _, out in parts if out.fix.size), None)
    names = ['x', 'y', 'fix', 'error_north', 'error_east']
    if first is not None:
        names += list(first.accuracy) + list(first.velocity)
        if first.lonlat is not None:
            names += ['lon', 'lat']
    cols = {k: np.full(n, np.nan) for k in names}
    where = np.flatnonzero(has)
    k0 = 0
    for sel, out in parts:
        m = int(sel.sum())
        idx = where[k0:k0 + m]
        k0 += m
        if not m:
            continue
        cols['x'][idx], cols['y'][idx] = out.x, out.y
        cols['fix'][idx] = out.fix
        cols['error_north'][idx], cols['error_east'][idx] = out.error[:, 0], out.error[:, 1]
        for k, v in {**out.accuracy, **out.velocity}.items():
            cols[k][idx] = v
        if out.lonlat is not None:
            cols['lon'][idx], cols['lat'][idx] = out.lonlat
    return cols


def _with_columns(table: Any, kinds: Sequence[str], cols: dict[str, FloatArray],
                  fix: BoolArray, has: BoolArray, errors: bool) -> Any:
    """Return ``table`` with the agents' x/y replaced and the new columns appended."""
    pa, _, pc = pyarrow_modules()
    for k in kinds:
        mine = np.asarray(pc.is_valid(table.column(f'{k}_id')).to_numpy(zero_copy_only=False),
                          dtype=bool)
        for axis in ('x', 'y'):
            name = f'{k}_{axis}'
            keep = ~(mine & has)
            moved = pa.array(cols[axis], mask=mine & has & ~fix)
            col = pc.if_else(pa.array(keep), table.column(name).combine_chunks(), moved)
            table = table.set_column(table.schema.get_field_index(name), name, col)
    table = table.append_column('fix', pa.array(fix, mask=~has))
    for k, v in cols.items():
        if k in ('x', 'y') or (k.startswith('error_') and not errors):
            continue
        table = table.append_column(k, pa.array(v, from_pandas=True))
    return table
