"""
Load a measured trace from any supported input: a trace CSV or a rosbag2.

A rosbag2 is a directory with ``metadata.yaml`` (MCAP or SQLite3 storage);
its ``.mcap``/``.db3`` file may be named instead. Fixes and truth are paired
at the fixes' stamps (:mod:`gps_error_ros.traces.pairing`).
"""

from pathlib import Path
from typing import Any, Optional, Sequence

from gps_error_ros.model.atomic import PathArg
from gps_error_ros.traces import bag_io
from gps_error_ros.traces.pairing import pair
from gps_error_ros.traces.progress import Progress
from gps_error_ros.traces.trace_io import read_trace_csv_counted, Trace, TraceError


def is_bag(path: PathArg) -> Optional[Path]:
    """Return the bag directory if ``path`` names a rosbag2, else None."""
    path = Path(path)
    if path.is_dir():
        if not (path / 'metadata.yaml').exists():
            raise bag_io.BagError(f'{path}: a directory but not a rosbag2 (no '
                                  f'metadata.yaml in it): expected a trace CSV '
                                  f'or a rosbag2 directory')
        return path
    if path.suffix.lower() in ('.mcap', '.db3') and \
            (path.parent / 'metadata.yaml').exists():
        return path.parent
    if path.suffix.lower() in ('.mcap', '.db3'):
        raise bag_io.BagError(f'{path}: a rosbag2 storage file without its '
                              f'metadata.yaml beside it: pass the bag directory')
    return None


def expand_inputs(paths: Sequence[PathArg]) -> list[Path]:
    """
    Return the recordings named by ``paths``, folders expanded, in order.

    A rosbag2 directory is one recording; any other folder stands for its
    trace CSVs and the rosbag2 directories in it, sorted by name. Raises
    :class:`TraceError` for a folder that holds neither.
    """
    out = []
    for path in ([paths] if isinstance(paths, (str, Path)) else paths):
        path = Path(path)
        if not path.is_dir() or (path / 'metadata.yaml').exists():
            out.append(path)
            continue
        found = sorted(p for p in path.iterdir()
                       if (p.is_file() and p.suffix.lower() == '.csv')
                       or (p.is_dir() and (p / 'metadata.yaml').exists()))
        if not found:
            raise TraceError(f'{path}: a folder with no trace CSV (*.csv) and no '
                             f'rosbag2 directory in it: expected recordings')
        out.extend(found)
    return out


def parse_datum(text: Optional[str]) -> Optional[tuple[float, ...]]:
    """Return (lat, lon, alt) from 'LAT,LON[,ALT]'."""
    if text is None:
        return None
    try:
        values = [float(v) for v in str(text).split(',')]
    except ValueError:
        values = []
    if len(values) not in (2, 3):
        raise ValueError(f'--datum {text!r}: expected LAT,LON or LAT,LON,ALT '
                         f'in degrees and metres')
    return tuple(values + [0.0] * (3 - len(values)))


def load_trace(path: PathArg, fix_topic: str = '/fix', truth_topic: str = '/pose',
               datum: Any = None, max_truth_gap: Optional[float] = None,
               agent: Optional[str] = None) -> tuple[Trace, list[str]]:
    """
    Return (Trace, notes): the paired trace and lines describing the loading.

    ``agent`` picks one agent of a trace CSV with an ``agent`` column. Raises
    the documented errors of the readers (TraceError, BagError, PairingError)
    with messages naming what was wrong.
    """
    bag = is_bag(path)
    if bag is None:
        trace, left_out = read_trace_csv_counted(path, agent)
        who = f' of agent {agent!r}' if agent is not None else ''
        notes = [f'{trace.name}: {len(trace)} rows{who}']
        if left_out['no_fix'] or left_out['no_truth']:
            notes.append(f'  left out as gaps: {left_out["no_fix"]} rows without a fix '
                         f'(lat or lon empty), {left_out["no_truth"]} without truth '
                         f'(truth_lat or truth_lon empty)')
        return trace, notes
    if agent is not None:
        raise ValueError(f'--agent {agent!r}: a rosbag2 has no agent column; '
                         f'choose the agent by --fix-topic and --truth-topic')
    total = bag_io.message_count(bag, (fix_topic, truth_topic)) \
        if fix_topic and truth_topic else 0
    progress = Progress(total, f'reading {bag.name}')
    try:
        fixes, truth, skipped = bag_io.read_fix_and_truth(
            bag, fix_topic, truth_topic, datum, progress)
    finally:
        progress.close()
    trace, stats = pair(fixes['t'], fixes['lat'], fixes['lon'], truth['t'],
                        truth['lat'], truth['lon'], max_truth_gap, bag.name)
    notes = [f'{bag.name}: {stats.describe()}']
    if skipped:
        notes.append(f'{skipped} fixes skipped (STATUS_NO_FIX or non-finite)')
    return trace, notes
