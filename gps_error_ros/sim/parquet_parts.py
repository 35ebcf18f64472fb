"""
A Parquet FCD file split by agent, its parts run on independent workers (Dask).

Every agent's errors depend only on the seed, its name and the model step,
counted from the run's first step. So a file split by agent
(:func:`split_by_agent`: each part holds some agents' rows, in time order)
can go to workers that share nothing. Each worker runs
:func:`~gps_error_ros.sim.simulate_parquet.simulate_parquet` on its part with the
whole file's first time (:func:`simulate_parts`), and the parts' outputs
hold exactly the rows the whole file's output holds. The workers are
Dask's: a local cluster of processes on this machine, or a cluster's
scheduler at an address. Needs the extras ``parquet`` and ``dask``.
"""

from collections.abc import Sequence
from dataclasses import dataclass
import os
from pathlib import Path
import shutil
from typing import Any, Generic
import zlib

import numpy as np

from gps_error_ros.model.atomic import PathArg
from gps_error_ros.model.protocol import S
from gps_error_ros.sim.fcd_step import FcdRequest
from gps_error_ros.traces.fcd_parquet import FcdParquet, pyarrow_modules, WriteBehind
from gps_error_ros.traces.trajectories import TrajectoryError

DASK_HINT = ('running parts on workers needs Dask: pip install "gps_error_ros[dask]" '
             '(or make setup)')


def part_of(names: Sequence[str], parts: int) -> Any:
    """Return each agent's part (0 .. parts - 1), stable across runs and machines (CRC-32)."""
    return np.array([zlib.crc32(n.encode()) % parts for n in names], dtype=np.int64)


def split_by_agent(src: PathArg, dst: PathArg, parts: int) -> list[Path]:
    """
    Split a Parquet FCD file by agent into ``parts`` files in directory ``dst``.

    Each part keeps its agents' rows in the file's order, every column; a
    row with no agent goes to part 0. Returns the parts' paths
    (``part-000.parquet``, ...). One streamed pass: memory stays bounded.
    """
    pa, _, _ = pyarrow_modules()
    if parts < 1:
        raise ValueError(f'parts {parts}: expected at least 1')
    fcd = FcdParquet(src)
    out = Path(dst)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / f'part-{i:03d}.parquet' for i in range(parts)]
    writers = [WriteBehind(p) for p in paths]
    try:
        for chunk in fcd.chunks():
            known = part_of(chunk.dictionary, parts)
            where = np.where(chunk.codes >= 0, known[np.maximum(chunk.codes, 0)], 0) \
                if known.size else np.zeros(chunk.codes.size, dtype=np.int64)
            for i, w in enumerate(writers):
                w.write(chunk.table.filter(pa.array(where == i)))
    finally:
        for w in writers:
            w.close()
    return paths


@dataclass(frozen=True)
class PartJob(Generic[S]):
    """What one worker needs to run one part (sent to it whole)."""

    src: str
    dst: str
    start_s: float
    request: FcdRequest[S]


def run_part(job: PartJob[S]) -> dict[str, int]:
    """Run one part on a worker; return its counts."""
    from gps_error_ros.sim.simulate_parquet import simulate_parquet
    return simulate_parquet(job.src, job.dst, job.request, start_s=job.start_s)


def simulate_parts(src: PathArg, dst: PathArg, request: FcdRequest[S],
                   scheduler: str | None = None, workers: int | None = None) -> dict[str, int]:
    """
    Run every part of directory ``src`` (``*.parquet``) on Dask's workers into directory ``dst``.

    ``request``: the model and the options, as for
    :func:`~gps_error_ros.sim.simulate_parquet.simulate_parquet`.
    ``scheduler``: a Dask scheduler's address (``tcp://host:8786``);
    without it, a local cluster of ``workers`` processes (default: one per
    core), on loopback. Each part's output has the part's name; the
    counts are summed. ``dst`` appears whole or not at all.
    """
    parts = sorted(Path(src).glob('*.parquet'))
    if not parts:
        raise TrajectoryError(f'{src}: no *.parquet parts: expected a directory of Parquet '
                              f'FCD files split by agent (gps_error split)')
    starts = [t for t in (FcdParquet(p).first_time() for p in parts) if t is not None]
    if not starts:
        raise TrajectoryError(f'{src}: {len(parts)} parts and no rows in any')
    out = Path(dst)
    if out.exists():
        raise TrajectoryError(f'{dst}: exists: expected a new directory for the parts\' output')
    tmp = out.with_name(f'.{out.name}.partial-{os.getpid()}')
    tmp.mkdir(parents=True)
    jobs = [PartJob(str(p), str(tmp / p.name), min(starts), request) for p in parts]
    try:
        results = _on_dask(jobs, scheduler, workers)
        os.replace(tmp, out)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp)
    total: dict[str, int] = {'parts': len(parts)}
    for r in results:                   # timesteps: the parts share them
        for k, v in r.items():
            total[k] = max(total.get(k, 0), v) if k == 'timesteps' else total.get(k, 0) + v
    return total


def _on_dask(jobs: Sequence[PartJob[S]], scheduler: str | None,
             workers: int | None) -> list[dict[str, int]]:
    """Run ``jobs`` on a Dask cluster (the scheduler's, or a local one); return their results."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise TrajectoryError(DASK_HINT) from None
    # distributed has no type hints: its calls are unchecked here
    if scheduler is not None:
        with Client(scheduler) as client:  # type: ignore[no-untyped-call]
            return list(client.gather(client.map(run_part, jobs, pure=False)))
    n = workers or os.cpu_count() or 1
    cluster = LocalCluster(  # type: ignore[no-untyped-call]
        n_workers=n, threads_per_worker=1, processes=True, host='127.0.0.1',
        dashboard_address=None)
    with cluster, Client(cluster) as client:  # type: ignore[no-untyped-call]
        return list(client.gather(client.map(run_part, jobs, pure=False)))
