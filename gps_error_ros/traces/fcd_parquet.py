"""
SUMO's FCD as Parquet (``sumo --fcd-output fcd.parquet``), read and written column by column.

SUMO writes one row per agent and timestep: ``timestep_time`` and, per kind
of agent, ``<kind>_id``, ``<kind>_x``, ``<kind>_y`` and the kind's other
attributes (``person_speed``, ``vehicle_lane``, ...), null where the row is
another kind's. Rows come in time order; a timestep with nobody has no row.
:class:`FcdParquet` reads such a file a record batch at a time (bounded
memory, whatever the file's size) and yields the rows of whole timesteps;
:class:`ParquetOut` writes the same columns with the agents' x/y replaced
and the new ones appended. Needs the extra ``parquet`` (pyarrow).
"""

from collections.abc import Iterator
from dataclasses import dataclass
import functools
import queue
import threading
from typing import Any

import numpy as np

from gps_error_ros.model.atomic import PathArg
from gps_error_ros.model.state import FloatArray, IntArray
from gps_error_ros.traces.trajectories import TrajectoryError

#: SUMO's kinds of moving things in FCD, in the order its XML lists them.
KINDS = ('vehicle', 'person', 'container')
TIME = 'timestep_time'
INSTALL_HINT = ('Parquet FCD needs pyarrow: pip install "gps_error_ros[parquet]" '
                '(or make setup)')


def pyarrow_modules() -> tuple[Any, Any, Any]:
    """Return (pyarrow, pyarrow.parquet, pyarrow.compute), or refuse without the extra."""
    try:
        import pyarrow as pa
        import pyarrow.compute as pc
        import pyarrow.parquet as pq
    except ImportError:
        raise TrajectoryError(INSTALL_HINT) from None
    return pa, pq, pc


def is_parquet(path: PathArg) -> bool:
    """Return whether ``path`` is named as a Parquet file (``.parquet``)."""
    return str(path).lower().endswith('.parquet')


@dataclass
class Chunk:
    """
    Whole timesteps of rows, as read.

    ``table``: every column of those rows; ``t``: each row's time;
    ``dictionary``: the agents met in the chunk, and ``codes`` each row's
    place in it (-1: the row has no agent); ``names``: each row's agent
    (None where the row has none); ``x``, ``y``: its position (NaN
    without an agent); ``bounds``: where each timestep starts, and the end.
    """

    table: Any
    t: FloatArray
    dictionary: list[str]
    codes: IntArray
    names: Any
    x: FloatArray
    y: FloatArray
    bounds: IntArray

    def timesteps(self) -> Iterator[tuple[float, slice]]:
        """Yield (time, rows) per timestep."""
        for i0, i1 in zip(self.bounds[:-1].tolist(), self.bounds[1:].tolist()):
            yield float(self.t[i0]), slice(i0, i1)


class FcdParquet:
    """
    A Parquet FCD file, read whole timesteps at a time.

    Parameters
    ----------
    path
        The file.
    batch_rows
        Rows read at a time (a timestep larger than this is read whole).
    columns
        Columns to read (None: all, as the output carries them through).

    """

    def __init__(self, path: PathArg, batch_rows: int = 1 << 17,
                 columns: list[str] | None = None) -> None:
        pa, pq, _ = pyarrow_modules()
        self.path = path
        self.batch_rows = batch_rows
        try:
            # pre-buffering keeps what it read: memory grew with the file (decision 0039)
            self.file = pq.ParquetFile(path, pre_buffer=False, buffer_size=1 << 22)
        except FileNotFoundError:
            raise TrajectoryError(f'{path}: no such file') from None
        except (pa.ArrowException, OSError) as exc:
            raise TrajectoryError(f'{path}: not a readable Parquet file ({exc}): expected '
                                  f'SUMO\'s --fcd-output FILE.parquet') from None
        self.schema = self.file.schema_arrow
        names = set(self.schema.names)
        if TIME not in names:
            raise TrajectoryError(f'{path}: no column {TIME!r}: expected SUMO\'s FCD as '
                                  f'Parquet (columns {TIME}, person_id, person_x, ...); '
                                  f'has {", ".join(self.schema.names[:8])}')
        self.kinds = [k for k in KINDS if {f'{k}_id', f'{k}_x', f'{k}_y'} <= names]
        if not self.kinds:
            raise TrajectoryError(f'{path}: no agents\' columns: expected <kind>_id, '
                                  f'<kind>_x and <kind>_y for a kind of {", ".join(KINDS)} '
                                  f'(SUMO\'s FCD as Parquet)')
        self.columns = columns
        self.rows = self.file.metadata.num_rows
        self._last: tuple[Any, list[str], Any] | None = None     # the last chunk's agents

    def first_time(self) -> float | None:
        """Return the time of the first row with an agent (None: none), reading a few columns."""
        _, _, pc = pyarrow_modules()
        ids = [f'{k}_id' for k in self.kinds]
        for batch in self.file.iter_batches(batch_size=1 << 14, columns=[TIME, *ids]):
            valid = [pc.is_valid(batch.column(c)) for c in ids]
            has = functools.reduce(pc.or_, valid)
            found = np.flatnonzero(np.asarray(has.to_numpy(zero_copy_only=False)))
            if found.size:
                return float(batch.column(TIME)[int(found[0])].as_py())
        return None

    def chunks(self) -> Iterator[Chunk]:
        """Yield the file's rows as :class:`Chunk` s of whole timesteps, in order."""
        pa, _, _ = pyarrow_modules()
        pending = None
        last = -np.inf
        try:
            for batch in self.file.iter_batches(batch_size=self.batch_rows,
                                                columns=self.columns):
                table = pa.Table.from_batches([batch])
                if pending is not None:
                    table = pa.concat_tables([pending, table])
                t = self._times(table, last)
                cut = int(np.searchsorted(t, t[-1], side='left'))
                if cut == 0:                 # one timestep so far: read on
                    pending = table
                    continue
                yield self._chunk(table.slice(0, cut), t[:cut])
                last = float(t[cut - 1])
                pending = table.slice(cut)
        except (pa.ArrowException, OSError) as exc:
            raise TrajectoryError(f'{self.path}: the file is corrupt or truncated ({exc}): '
                                  f'expected a whole Parquet file as SUMO writes it') from None
        if pending is not None and pending.num_rows:
            yield self._chunk(pending, self._times(pending, last))

    def _times(self, table: Any, last: float) -> FloatArray:
        """Return the rows' times; refuse nulls and times that go back."""
        col = table.column(TIME)
        if col.null_count:
            raise TrajectoryError(f'{self.path}: {col.null_count} rows without a '
                                  f'{TIME}: expected a time on every row')
        t = np.asarray(col.to_numpy(), dtype=float)
        back = np.flatnonzero(np.diff(t) < 0)
        if back.size or (t.size and t[0] < last):
            at = float(t[back[0] + 1]) if back.size else float(t[0])
            before = float(t[back[0]]) if back.size else last
            raise TrajectoryError(f'{self.path}: {TIME} {at} after {before}: expected rows '
                                  f'in time order (as SUMO writes them)')
        return t

    def _chunk(self, table: Any, t: FloatArray) -> Chunk:
        """Return whole timesteps' rows with each row's agent and position."""
        _, _, pc = pyarrow_modules()
        cols = [table.column(f'{k}_id') for k in self.kinds]
        ids = (pc.coalesce(*cols) if len(cols) > 1 else cols[0]).combine_chunks()
        enc = pc.dictionary_encode(ids)
        if self._last is None or not enc.dictionary.equals(self._last[0]):
            # the same agents in the same order: the same list, which lookups cache by
            listed = enc.dictionary.to_pylist()
            self._last = (enc.dictionary, listed, np.array(listed + [None], dtype=object))
        _, dictionary, named = self._last
        codes = np.asarray(enc.indices.fill_null(-1).to_numpy(), dtype=np.int64)
        names = named[codes]
        x = self._coalesced(table, '_x')
        y = self._coalesced(table, '_y')
        starts = np.flatnonzero(np.diff(t)) + 1
        bounds = np.concatenate([[0], starts, [t.size]]).astype(np.int64)
        return Chunk(table, t, dictionary, codes, names, x, y, bounds)

    def _coalesced(self, table: Any, suffix: str) -> FloatArray:
        """Return the kinds' column ``suffix`` as one float array (NaN where null)."""
        _, _, pc = pyarrow_modules()
        cols = [table.column(f'{k}{suffix}') for k in self.kinds]
        col = pc.coalesce(*cols) if len(cols) > 1 else cols[0]
        return np.asarray(col.to_numpy(zero_copy_only=False), dtype=float)


_DONE = object()


def read_ahead(items: Iterator[Any], depth: int = 2) -> Iterator[Any]:
    """
    Yield ``items``, produced in a thread of their own ``depth`` ahead of the consumer.

    Arrow decodes and numpy computes with the interpreter's lock released,
    so reading the next chunk overlaps the work on this one. An exception
    raised while producing is raised here, in order.
    """
    box: queue.Queue[Any] = queue.Queue(maxsize=depth)
    stop = threading.Event()

    def produce() -> None:
        try:
            for item in items:
                if stop.is_set():
                    return
                box.put(item)
            box.put(_DONE)
        except BaseException as exc:        # handed to the consumer, raised there
            box.put(_Raised(exc))

    thread = threading.Thread(target=produce, name='fcd-read', daemon=True)
    thread.start()
    try:
        while True:
            item = box.get()
            if item is _DONE:
                return
            if isinstance(item, _Raised):
                raise item.exc
            yield item
    finally:
        stop.set()
        while thread.is_alive():            # let a blocked producer finish
            try:
                box.get_nowait()
            except queue.Empty:
                thread.join(0.05)


@dataclass
class _Raised:
    exc: BaseException


def writer_options(schema: Any) -> dict[str, Any]:
    """
    Return the Parquet writer's options for a table of ``schema`` (decision 0041).

    Only the string columns (ids, types, edges, lanes) are dictionary-encoded:
    pyarrow's default also hashes every double, which made writing cost
    three times reading, for a larger file. Statistics (min and max per
    row group) are written for the time, which readers filter by.
    """
    pa, _, _ = pyarrow_modules()
    text = [f.name for f in schema
            if pa.types.is_string(f.type) or pa.types.is_large_string(f.type)
            or pa.types.is_dictionary(f.type)]
    return {'use_dictionary': text,
            'write_statistics': [TIME] if TIME in schema.names else False}


class WriteBehind:
    """
    A Parquet writer that writes in a thread of its own, a table or two behind.

    :meth:`write` hands a table over and returns; :meth:`close` waits for
    every table, closes the file and raises what the writer raised.
    """

    def __init__(self, path: PathArg, depth: int = 2) -> None:
        self.path = path
        self.box: queue.Queue[Any] = queue.Queue(maxsize=depth)
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run, name='fcd-write', daemon=True)
        self.thread.start()

    def write(self, table: Any) -> None:
        """Queue ``table`` to be written (the first sets the file's schema)."""
        if self.error is not None:
            raise self.error
        self.box.put(table)

    def close(self) -> None:
        """Write what is queued, close the file; raise the writer's error, if any."""
        self.box.put(_DONE)
        self.thread.join()
        if self.error is not None:
            raise self.error

    def _run(self) -> None:
        _, pq, _ = pyarrow_modules()
        writer = None
        try:
            while (table := self.box.get()) is not _DONE:
                if self.error is not None:
                    continue                # drain: the consumer learns at its next write
                if writer is None:
                    writer = pq.ParquetWriter(self.path, table.schema,
                                              **writer_options(table.schema))
                writer.write_table(table)
        except BaseException as exc:
            self.error = exc
            while self.box.get() is not _DONE:
                pass
        finally:
            if writer is not None:
                writer.close()
