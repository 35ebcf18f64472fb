"""
Read measured traces: the canonical trace CSV (the format of the repository's ``data/README.md``).

One header line, comma-separated, one row per fix sorted by ``t`` (seconds):
``t, lat, lon, truth_lat, truth_lon`` are required; ``alt``, ``truth_alt``,
``speed``, ``accuracy``, ``nsat``, ``mean_cn0``, ``bearing``, ``hdop``,
``truth_speed`` and ``truth_bearing`` are optional (cells may be empty), and so
is ``agent`` (text: the file then holds several agents' traces,
one chosen by name). Other columns are ignored. A UTF-8 byte-order mark and
Windows line endings are accepted. An empty cell means "not available": a
row whose ``lat`` or ``lon`` is empty has no fix and one whose ``truth_lat``
or ``truth_lon`` is empty no truth; either is left out (a gap), and counted.
"""

import csv
from dataclasses import dataclass, field
import math
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np

from gps_error_ros.model.atomic import atomic_output, PathArg
from gps_error_ros.model.state import FloatArray, IntArray, Numbers


REQUIRED = ('t', 'lat', 'lon', 'truth_lat', 'truth_lon')
#: Required columns whose empty cell means "not available" (the row is a gap).
MAY_BE_EMPTY = ('lat', 'lon', 'truth_lat', 'truth_lon')
OPTIONAL = ('alt', 'truth_alt', 'speed', 'accuracy', 'nsat', 'mean_cn0', 'bearing',
            'hdop', 'truth_speed', 'truth_bearing', 'accuracy_major', 'accuracy_minor',
            'accuracy_orientation')
#: Values of the optional ``status`` column (``gps_error simulate`` with outages).
STATUSES = ('fix', 'no_fix')


class TraceError(ValueError):
    """A trace file that does not match the trace CSV format."""


@dataclass(frozen=True)
class Trace:
    """A measured trace: fixes and the ground truth at the same instants."""

    name: str
    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    truth_lat: np.ndarray
    truth_lon: np.ndarray
    extra: dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        """Return the number of fixes."""
        return self.t.size


def _header_and_rows(path: Path) -> tuple[list[str], list[list[str]]]:
    """Return (header, data rows) of a trace CSV; refuse what cannot be one."""
    try:
        text = path.read_text(encoding='utf-8-sig')
    except FileNotFoundError:
        raise TraceError(f'{path}: file not found') from None
    except (OSError, UnicodeDecodeError) as exc:
        raise TraceError(f'{path}: cannot read: {exc}') from None
    rows = list(csv.reader(text.splitlines()))
    if not rows or not any(c.strip() for c in rows[0]):
        raise TraceError(f'{path}: empty file: expected a header line with '
                         f'columns {list(REQUIRED)}')
    header = [c.strip() for c in rows[0]]
    missing = [c for c in REQUIRED if c not in header]
    if missing:
        raise TraceError(f'{path}: missing column(s) {missing}: expected at '
                         f'least {list(REQUIRED)}, found {header}')
    body = [r for r in rows[1:] if any(c.strip() for c in r)]
    if len(body) < 2:
        raise TraceError(f'{path}: {len(body)} data row(s): a trace needs at '
                         f'least 2')
    return header, body


def _column(path: Path, body: list[list[str]], i: int, name: str) -> FloatArray:
    """Return column ``i`` as floats (empty optional cells NaN), checked."""
    values = np.empty(len(body))
    for r, row in enumerate(body, start=2):
        cell = row[i].strip() if i < len(row) else ''
        if cell == '' and (name in OPTIONAL or name in MAY_BE_EMPTY):
            values[r - 2] = np.nan
            continue
        try:
            v = float(cell)
        except ValueError:
            raise TraceError(f'{path}: line {r}, column {name!r}: expected '
                             f'a number, got {cell!r}') from None
        if not math.isfinite(v) and name in REQUIRED:
            raise TraceError(f'{path}: line {r}, column {name!r}: expected '
                             f'a finite number, got {cell!r}')
        values[r - 2] = v
    return values


def _fix_rows(path: Path, body: list[list[str]], i: int) -> list[list[str]]:
    """Return the rows whose ``status`` is ``fix``; refuse another value."""
    out = []
    for r, row in enumerate(body, start=2):
        cell = row[i].strip() if i < len(row) else ''
        if cell not in STATUSES:
            raise TraceError(f'{path}: line {r}, column \'status\': expected one of '
                             f'{list(STATUSES)}, got {cell!r}')
        if cell == 'fix':
            out.append(row)
    if len(out) < 2:
        raise TraceError(f'{path}: {len(out)} row(s) with status fix: a trace needs '
                         f'at least 2')
    return out


def _agent_rows(path: Path, header: list[str], body: list[list[str]],
                agent: Optional[str]) -> list[list[str]]:
    """Return the rows of ``agent`` (a trace CSV with an ``agent`` column)."""
    i = header.index('agent')
    names = [r[i].strip() if i < len(r) else '' for r in body]
    held = list(dict.fromkeys(names))
    listing = ', '.join(repr(n) for n in held[:10]) + (', ...' if len(held) > 10 else '')
    if agent is None:
        if len(held) == 1:
            return body
        raise TraceError(f'{path}: holds {len(held)} agents ({listing}): pass '
                         f'--agent NAME to choose one')
    rows = [r for r, n in zip(body, names) if n == agent]
    if len(rows) < 2:
        raise TraceError(f'{path}: agent {agent!r}: {len(rows)} row(s); the file '
                         f'holds {len(held)} agent(s): {listing}')
    return rows


def read_trace_csv(path: PathArg, agent: Optional[str] = None) -> Trace:
    """
    Read and validate a trace CSV.

    A file with an ``agent`` column (``gps_error simulate`` writes one) holds
    several agents' traces; ``agent`` picks one (needed when there are
    several). Rows without a fix or without truth (empty cells) are left
    out; :func:`read_trace_csv_counted` also says how many.

    Parameters
    ----------
    path
        The CSV file.
    agent
        The agent to read, in a file with an ``agent`` column.

    Returns
    -------
    Trace
        The trace, validated.

    Raises
    ------
    TraceError
        Naming the file, the row or column, and what was expected.

    """
    return read_trace_csv_counted(path, agent)[0]


def read_trace_csv_counted(path: PathArg,
                           agent: Optional[str] = None) -> tuple[Trace, dict[str, int]]:
    """
    Return (:func:`read_trace_csv`'s trace, the rows left out by why).

    The second is a dict: ``no_fix`` (``lat`` or ``lon`` empty) and
    ``no_truth`` (a fix, but ``truth_lat`` or ``truth_lon`` empty).
    """
    path = Path(path)
    header, body = _header_and_rows(path)
    if 'agent' in header:
        body = _agent_rows(path, header, body, agent)
    elif agent is not None:
        raise TraceError(f'{path}: no agent column, so no agent {agent!r}: '
                         f'found columns {header}')
    cols = {c: i for i, c in enumerate(header)}
    if 'status' in cols:            # gps_error simulate's outages: gaps, not fixes
        body = _fix_rows(path, body, cols['status'])
    data = {name: _column(path, body, cols[name], name)
            for name in REQUIRED + OPTIONAL if name in cols}
    t = data['t']
    step = np.diff(t)
    if np.any(step <= 0):
        r = int(np.flatnonzero(step <= 0)[0]) + 3
        kind = 'duplicate' if step[r - 3] == 0 else 'decreasing'
        raise TraceError(f'{path}: line {r}: {kind} time t={float(t[r - 2])!r} after '
                         f'{float(t[r - 3])!r}: expected strictly increasing t')
    no_fix = np.isnan(data['lat']) | np.isnan(data['lon'])
    no_truth = ~no_fix & (np.isnan(data['truth_lat']) | np.isnan(data['truth_lon']))
    keep = ~(no_fix | no_truth)
    if keep.sum() < 2:
        raise TraceError(f'{path}: {int(keep.sum())} row(s) with a fix and its truth '
                         f'(lat, lon, truth_lat, truth_lon all given): a trace needs '
                         f'at least 2')
    data = {k: v[keep] for k, v in data.items()}
    for lat_col, lon_col in (('lat', 'lon'), ('truth_lat', 'truth_lon')):
        bad = np.flatnonzero((np.abs(data[lat_col]) > 90)
                             | (np.abs(data[lon_col]) > 180))
        if bad.size:
            line = int(np.flatnonzero(keep)[bad[0]]) + 2
            raise TraceError(f'{path}: line {line}: {lat_col}/{lon_col} '
                             f'out of range: expected |lat| <= 90, |lon| <= 180')
    trace = Trace(name=path.name, t=data['t'], lat=data['lat'], lon=data['lon'],
                  truth_lat=data['truth_lat'], truth_lon=data['truth_lon'],
                  extra={k: data[k] for k in OPTIONAL if k in data})
    return trace, {'no_fix': int(no_fix.sum()), 'no_truth': int(no_truth.sum())}


#: Seconds put between two recordings joined into one trace: longer than any
#: window a fit looks through (the reported-accuracy fit's 31 s), so no fit
#: pairs a sample of one recording with one of another.
RECORDING_GAP_S = 100.0
#: The extra column of a joined trace that says which recording a row came from.
RECORDING = 'recording'


def recordings_of(traces: Trace | Sequence[Trace]) -> list[Trace]:
    """Return ``traces`` as a list: one :class:`Trace`, or a sequence of them."""
    if isinstance(traces, Trace):
        return [traces]
    out = list(traces)
    if not out or not all(isinstance(t, Trace) for t in out):
        raise TraceError(f'expected a trace or a non-empty sequence of traces, got '
                         f'{traces!r}')
    return out


def recording_offsets(traces: Sequence[Trace],
                      gap_s: float = RECORDING_GAP_S) -> list[float]:
    """Return where each recording starts in :func:`join_recordings`'s time line, s."""
    out, start = [], 0.0
    for tr in recordings_of(traces):
        out.append(start)
        start += float(tr.t[-1] - tr.t[0]) + gap_s
    return out


def join_recordings(traces: Trace | Sequence[Trace],
                    gap_s: float = RECORDING_GAP_S) -> Trace:
    """
    Return one :class:`Trace` of several recordings, each after the last.

    Each recording's times keep their spacing and start ``gap_s`` seconds
    after the previous one ends, so that a fit on the model grid sees the
    recordings as separate segments. One recording is returned as it is.
    The extra columns are those every recording has, and
    :data:`RECORDING`: each row's recording, counted from 0 (a recording
    that was itself joined keeps its own recordings apart), so that what
    judges the joined trace can restart at each recording's start.
    """
    traces = recordings_of(traces)
    if len(traces) == 1:
        return traces[0]
    labels, first = [], 0
    for tr in traces:
        own = np.asarray(tr.extra.get(RECORDING, np.zeros(len(tr))), dtype=float)
        labels.append(own + first)
        first += int(own.max()) + 1 if own.size else 1
    shared = [k for k in traces[0].extra if all(k in t.extra for t in traces)
              and k != RECORDING]
    times = [tr.t - tr.t[0] + start
             for tr, start in zip(traces, recording_offsets(traces, gap_s))]
    name = f'{len(traces)} recordings (' + ', '.join(t.name for t in traces) + ')'
    return Trace(name=name, t=np.concatenate(times),
                 lat=np.concatenate([t.lat for t in traces]),
                 lon=np.concatenate([t.lon for t in traces]),
                 truth_lat=np.concatenate([t.truth_lat for t in traces]),
                 truth_lon=np.concatenate([t.truth_lon for t in traces]),
                 extra={**{k: np.concatenate([t.extra[k] for t in traces]) for k in shared},
                        RECORDING: np.concatenate(labels)})


def recording_labels(trace: Trace) -> IntArray:
    """Return each row's recording (:func:`join_recordings`; zeros for one recording)."""
    return np.asarray(trace.extra.get(RECORDING, np.zeros(len(trace))), dtype=np.int64)


def write_trace_csv(trace: Trace, path: PathArg, agent: Optional[str] = None,
                    fix: Optional[Numbers] = None) -> PathArg:
    """
    Write ``trace`` as a trace CSV: the one writer of the format read above.

    Columns: ``t``, then ``agent`` when given (one name per row), then
    ``status`` when ``fix`` (a boolean per row) is given (``fix``/``no_fix``;
    a no-fix row's lat/lon are empty, and readers skip it as a gap), then
    ``lat, lon, truth_lat, truth_lon`` and the trace's optional columns.
    Numbers are written with ``repr`` (round trip exact); a non-finite
    value as an empty cell. Returns ``path``.
    """
    path = Path(path)
    with atomic_output(path) as tmp:
        _write_rows(trace, tmp, agent, fix)
    return path


def _write_rows(trace: Trace, path: Path, agent: Optional[str], fix: Optional[Numbers]) -> None:
    cols = ['t'] + (['agent'] if agent is not None else []) + \
        (['status'] if fix is not None else []) + \
        ['lat', 'lon', 'truth_lat', 'truth_lon'] + list(trace.extra)
    data = [trace.t, trace.lat, trace.lon, trace.truth_lat, trace.truth_lon] + \
        list(trace.extra.values())
    names = agent if agent is not None else [None] * len(trace)
    status = [None] * len(trace) if fix is None else \
        ['fix' if f else 'no_fix' for f in fix]
    with open(path, 'w', encoding='utf-8', newline='') as f:
        f.write(','.join(cols) + '\n')
        for name, st, *row in zip(names, status, *data):
            cells = ['' if not math.isfinite(v) else repr(float(v)) for v in row]
            if st is not None:
                cells.insert(1, st)
            if name is not None:
                cells.insert(1, _csv_cell(name))
            f.write(','.join(cells) + '\n')


def _csv_cell(text: str) -> str:
    text = str(text)
    if any(c in text for c in ',"\n\r'):
        return '"' + text.replace('"', '""') + '"'
    return text
