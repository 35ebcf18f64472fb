"""
``gps_error simulate``: smartphone GPS errors for simulators without ROS.

Three modes, all with the error node's per-agent streams (same seed, agent
names and first step give the same errors):

* SUMO FCD in, FCD out with noisy positions (streamed);
* a CSV of true positions (``t, truth_lat, truth_lon[, agent]``) in, a trace
  CSV out (``t, agent, lat, lon, truth_lat, truth_lon``), which
  ``gps_error calibrate`` reads back;
* no input: ``--agents N --duration S`` writes the raw error series to an
  ``.npz`` (streamed to disk, agents x steps x (north, east) metres).

A profile's ``effects`` apply in every mode, except ``motion_lag`` in the
``.npz`` mode, which has no trajectory to lag (the two trajectory modes
report each agent's position ``lag_s`` earlier, interpolated).

With a zone map (``zones``: ``(ZoneMap, StepsPerFix)``, see
:func:`gps_error_ros.model.zoned.zoned_errors`) the two trajectory modes give each agent the error
process of the zone its (lagged) truth is in, step by step
(:mod:`gps_error_ros.model.zoned`), as the node with ``zones`` does; the
accuracy columns follow the zone.
"""

from collections.abc import Mapping, Sequence
import datetime as dt
import math
import os
from pathlib import Path
import re
import zipfile

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.atomic import atomic_output, PathArg
from gps_error_ros.model.protocol import ErrorModel, S
from gps_error_ros.model.reported import ReportedAccuracy
from gps_error_ros.model.state import Numbers
from gps_error_ros.model.velocity import Velocity
from gps_error_ros.model.zoned import ZoneSetup
from gps_error_ros.sim.faults import Fault
from gps_error_ros.sim.fcd_step import (FcdColumns, fcd_counts, FcdOptions, FcdSteps,
                                        xml_position_mode)
from gps_error_ros.sim.trajectory_fixes import (accuracy_columns, agent_names, model_step,
                                                trajectory_fixes)
from gps_error_ros.traces.progress import Progress
from gps_error_ros.traces.nmea_write import epoch_sentences
from gps_error_ros.traces.trace_io import Trace, write_trace_csv
from gps_error_ros.traces.trajectories import (FcdWriter, iter_fcd, read_truth_csv,
                                               TrajectoryError)


def simulate_fcd(src: PathArg, dst: PathArg, model: ErrorModel[S], rate_hz: float, seed: int,
                 net: PathArg | None = None, coordinates: str | None = None,
                 digits: int | None = None, zones: ZoneSetup | None = None,
                 covariance_mode: str = 'stationary', reported: ReportedAccuracy | None = None,
                 velocity: Velocity | None = None,
                 reported_bias: Numbers | None = None,
                 faults: Sequence[Fault] = (), errors: bool = False) -> dict[str, int]:
    """
    Add errors to every agent of a SUMO FCD file; return counts (see module doc).

    ``digits``: digits after the decimal point of the positions written
    (default 8 for lon/lat, about a millimetre, and 3 for metres). Every
    position written also gets the attributes ``accuracy``,
    ``accuracy_major``, ``accuracy_minor`` (m) and ``accuracy_orientation``
    (deg from north) of the CSV mode, from the covariance of
    ``covariance_mode`` (``reported``: the radius the profile's
    ``reported_accuracy`` states); an agent in an outage gets no position at all.
    With ``velocity`` (a profile's :class:`Velocity`) a position also gets
    the phone's ``reported_speed`` (m/s) and ``reported_bearing`` (deg from
    north; none at a standstill), as the CSV mode's ``speed`` and
    ``bearing`` (SUMO's own ``speed`` and ``angle`` stay the truth's).
    With ``errors`` a position also gets its ``error_north`` and
    ``error_east`` (m, to the last bit). The run starts at the first
    timestep with an agent in it.
    """
    with atomic_output(dst) as tmp:
        return _simulate_fcd(src, tmp, model, rate_hz, seed, net, coordinates, digits,
                             zones, covariance_mode, reported, velocity, reported_bias, faults,
                             errors)


def simulate_csv(src: PathArg, dst: PathArg, model: ErrorModel[S], rate_hz: float, seed: int,
                 velocity: Velocity | None = None, covariance_mode: str = 'stationary',
                 zones: ZoneSetup | None = None, reported: ReportedAccuracy | None = None,
                 reported_bias: Numbers | None = None,
                 faults: Sequence[Fault] = ()) -> dict[str, int]:
    """
    Add errors to a CSV of true positions; write a trace CSV; return counts.

    With ``velocity`` (a profile's :class:`Velocity`) the trace also gets the
    reported ``speed`` and ``bearing`` and the truth's ``truth_speed`` and
    ``truth_bearing`` (:mod:`velocity_sim`). Every row with a fix states its
    accuracy (:mod:`accuracy`) from the error covariance of
    ``covariance_mode``, as the node's: ``stationary``, ``conditional``, or
    ``reported`` (the radius ``reported``, a profile's
    :class:`ReportedAccuracy`, states, and the circular covariance it implies,
    plus ``reported_bias`` (the error's mean) as ``m m^T`` when given).
    ``faults`` (:mod:`~gps_error_ros.sim.faults`, times on ``t``) are laid
    over the fixes as the error node lays them; a row a fault touched states
    the accuracy of the fault's covariance.
    """
    with atomic_output(dst) as tmp:
        return _simulate_csv(src, tmp, model, rate_hz, seed, velocity, covariance_mode,
                             zones, reported, reported_bias, faults)


def simulate_nmea(src: PathArg, dst: PathArg, model: ErrorModel[S], rate_hz: float,
                  seed: int, utc0: dt.datetime, velocity: Velocity | None = None,
                  covariance_mode: str = 'stationary', zones: ZoneSetup | None = None,
                  reported: ReportedAccuracy | None = None,
                  reported_bias: Numbers | None = None,
                  faults: Sequence[Fault] = ()) -> dict[str, int]:
    """
    Add errors to one agent's CSV of true positions; write its fixes as NMEA 0183.

    The same fixes as :func:`simulate_csv` (same seed, profile and options),
    an epoch each (:func:`~gps_error_ros.traces.nmea_write.epoch_sentences`):
    a step in an outage as fix quality 0, and each fix's stated accuracy
    (the covariance of ``covariance_mode``) in GST and HDOP. ``utc0`` is the
    UTC instant of ``t = 0`` (the Unix epoch when ``t`` is Unix time). A file
    is one receiver's stream: more than one agent is refused.
    """
    agents = sorted(set(read_truth_csv(src)['agent']))
    if len(agents) != 1:
        raise TrajectoryError(f'{src}: {len(agents)} agents ({", ".join(agents[:5])}'
                              f'{" ..." if len(agents) > 5 else ""}): an NMEA file is one '
                              f'receiver\'s stream; write a .csv, or give one agent\'s rows')
    with atomic_output(dst) as tmp:
        csv_tmp = Path(str(tmp) + '.csv')
        try:
            res = _simulate_csv(src, csv_tmp, model, rate_hz, seed, velocity, covariance_mode,
                                zones, reported, reported_bias, faults)
            epochs = _nmea_epochs(csv_tmp, utc0)
        finally:
            csv_tmp.unlink(missing_ok=True)
        with open(tmp, 'w', newline='') as f:
            for sentences in epochs:
                f.write('\r\n'.join(sentences) + '\r\n')
    return res


def _nmea_epochs(path: Path, utc0: dt.datetime) -> list[list[str]]:
    """Return the NMEA sentences of each row of a trace CSV ``simulate`` wrote (one agent)."""
    import csv
    with open(path, newline='') as f:
        rows = list(csv.DictReader(f))

    def num(row: Mapping[str, str], key: str) -> float:
        text = row.get(key) or ''
        return float(text) if text else math.nan

    out = []
    for r in rows:
        major, minor = num(r, 'accuracy_major'), num(r, 'accuracy_minor')
        theta = math.radians(num(r, 'accuracy_orientation'))
        u, v = (math.cos(theta), math.sin(theta)), (-math.sin(theta), math.cos(theta))
        cov = [[major ** 2 * u[i] * u[j] + minor ** 2 * v[i] * v[j] for j in (0, 1)]
               for i in (0, 1)]
        fix = r.get('status', 'fix') != 'no_fix' and r['lat'] != ''
        alt = num(r, 'alt')
        out.append(epoch_sentences(
            utc0 + dt.timedelta(seconds=float(r['t'])), num(r, 'lat'), num(r, 'lon'),
            0.0 if math.isnan(alt) else alt, fix, cov if math.isfinite(major) else None,
            speed=num(r, 'speed'), course=num(r, 'bearing')))
    return out


def simulate_npz(dst: PathArg, model: ErrorModel[S], rate_hz: float, seed: int, n_agents: int,
                 duration_s: float, start_s: float = 0.0, prefix: str = 'agent',
                 chunk: int = 1024) -> dict[str, int]:
    """Write raw error series to ``dst`` (.npz); return counts (see module doc)."""
    with atomic_output(dst) as tmp:
        return _simulate_npz(tmp, model, rate_hz, seed, n_agents, duration_s,
                             start_s, prefix, chunk)


def _simulate_fcd(src: PathArg, dst: PathArg, model: ErrorModel[S], rate_hz: float, seed: int,
                  net: PathArg | None = None, coordinates: str | None = None,
                  digits: int | None = None, zones: ZoneSetup | None = None,
                  covariance_mode: str = 'stationary', reported: ReportedAccuracy | None = None,
                  velocity: Velocity | None = None,
                  reported_bias: Numbers | None = None,
                  faults: Sequence[Fault] = (), errors: bool = False) -> dict[str, int]:
    """Add errors to every agent of a SUMO FCD file; return counts (one streamed pass)."""
    mode, proj = xml_position_mode(src, net, coordinates)
    steps = FcdSteps(src, model, FcdOptions(mode, proj, rate_hz, seed, covariance_mode, zones,
                                            reported, velocity, reported_bias, faults))
    progress = Progress(os.path.getsize(src), f'simulating {Path(src).name}', min_total=20 << 20)
    writer = FcdWriter(dst)
    rows, timesteps, no_fix = 0, 0, 0
    seen: set[str] = set()
    try:
        for t, elem, agents in iter_fcd(src, progress):
            timesteps += 1
            names = [a[0] for a in agents]
            seen.update(names)
            out = steps.timestep(t, names, [a[1] for a in agents], [a[2] for a in agents])
            writer.timestep(elem, [(a[3], over) for a, over, fix in
                                   zip(agents, _attributes(out, digits, errors), out.fix)
                                   if fix])
            rows += int(out.fix.sum())
            no_fix += int((~out.fix).sum())
    finally:
        writer.close()
        progress.close()
    return fcd_counts(src, model, timesteps, rows, len(seen), no_fix, bool(faults))


def _attributes(out: FcdColumns, digits: int | None, errors: bool) -> list[dict[str, str]]:
    """Return each agent's attributes to write: x, y, the accuracy, velocity and error ones."""
    fmt = f'{{:.{digits}f}}' if digits is not None else '{:.3f}' if out.metres else '{:.8f}'
    cols = {'x': formatted(out.x, fmt), 'y': formatted(out.y, fmt)}
    cols.update({k: formatted(v, '{:.3f}') for k, v in out.accuracy.items()})
    for k, v in out.velocity.items():
        cols[k] = formatted(v, '{:.2f}' if k == 'reported_bearing' else '{:.3f}')
    if errors:
        cols['error_north'] = formatted(out.error[:, 0], '{:.17g}')
        cols['error_east'] = formatted(out.error[:, 1], '{:.17g}')
    return [{k: text for k, c in cols.items() if (text := c[i]) is not None}
            for i in range(out.fix.size)]


def formatted(values: Numbers, fmt: str) -> Sequence[str | None]:
    """
    Return ``values`` as strings in ``fmt`` ('{:.Nf}' or '{:.Ng}'), None where not finite.

    One %-format over the whole array (done in C) instead of a call per
    value: the same digits, at a fraction of the cost for a crowd's
    timestep.
    """
    values = np.asarray(values, dtype=float)
    ok = np.isfinite(values)
    spec = re.fullmatch(r'\{:\.(\d+)([fg])\}', fmt)
    if spec is None:
        return [fmt.format(v) if o else None for v, o in zip(values.tolist(), ok.tolist())]
    text = ('\x1f'.join([f'%.{spec.group(1)}{spec.group(2)}'] * values.size)
            % tuple(values.tolist())).split('\x1f') if values.size else []
    if ok.all():
        return text
    return [v if o else None for v, o in zip(text, ok.tolist())]


def _simulate_csv(src: PathArg, dst: PathArg, model: ErrorModel[S], rate_hz: float, seed: int,
                  velocity: Velocity | None = None, covariance_mode: str = 'stationary',
                  zones: ZoneSetup | None = None, reported: ReportedAccuracy | None = None,
                  reported_bias: Numbers | None = None,
                  faults: Sequence[Fault] = ()) -> dict[str, int]:
    """Add errors to a CSV of true positions; write a trace CSV."""
    data = read_truth_csv(src)
    rows, radius = trajectory_fixes(data, model, rate_hz, seed, velocity, covariance_mode,
                                    zones, reported, reported_bias, faults, str(src))
    fix = rows.fix
    extra = accuracy_columns(rows.cov, fix, radius)
    extra.update(rows.extra)
    outages = model.has_outages or bool(faults)
    write_trace_csv(Trace(Path(dst).name, data['t'], rows.lat, rows.lon, data['truth_lat'],
                          data['truth_lon'], extra), dst, agent=data['agent'],
                    fix=fix if outages else None)
    out = {'positions': int(fix.sum()), 'agents': len(set(data['agent']))}
    if outages:
        out['positions_without_fix'] = int((~fix).sum())
    return out


def _simulate_npz(dst: PathArg, model: ErrorModel[S], rate_hz: float, seed: int, n_agents: int,
                  duration_s: float, start_s: float = 0.0, prefix: str = 'agent',
                  chunk: int = 1024) -> dict[str, int]:
    """
    Write raw error series to ``dst`` (.npz), streaming agent chunks to disk.

    Arrays: ``errors`` (agents, steps, 2) float64 north/east metres;
    ``t`` (steps,) seconds; ``names`` (agents,) strings; ``seed``, ``rate_hz``;
    with a profile's availability also ``fix`` (agents, steps) bool, False in
    an outage (the errors run on through it).
    """
    steps = int(round(duration_s * rate_hz))
    start = model_step(start_s, rate_hz)
    names = agent_names(n_agents, prefix)
    shape = (n_agents, steps, 2)
    progress = Progress(n_agents, f'simulating {n_agents} agents', min_total=1)
    with zipfile.ZipFile(dst, 'w', compression=zipfile.ZIP_STORED,
                         allowZip64=True) as zf:
        with zf.open('errors.npy', 'w', force_zip64=True) as f:
            np.lib.format.write_array_header_2_0(
                f, {'descr': '<f8', 'fortran_order': False, 'shape': shape})
            for a0 in range(0, n_agents, chunk):
                keys = np.array([streams.agent_key(seed, n)
                                 for n in names[a0:a0 + chunk]], dtype=np.uint64)
                block = model.simulate(keys, steps, start=start)
                f.write(np.ascontiguousarray(block.transpose(1, 0, 2)).tobytes())
                progress.update(keys.size)
        if model.has_outages:         # fix[a, k]: False in an outage
            with zf.open('fix.npy', 'w', force_zip64=True) as f:
                np.lib.format.write_array_header_2_0(
                    f, {'descr': '|b1', 'fortran_order': False, 'shape': shape[:2]})
                for a0 in range(0, n_agents, chunk):
                    keys = np.array([streams.agent_key(seed, n)
                                     for n in names[a0:a0 + chunk]], dtype=np.uint64)
                    f.write(np.ascontiguousarray(
                        model.simulate_fix(keys, steps, start=start)).tobytes())
        for name, arr in (('t', (start + np.arange(steps)) / rate_hz),
                          ('names', np.array(names)), ('seed', np.array(seed)),
                          ('rate_hz', np.array(rate_hz))):
            with zf.open(f'{name}.npy', 'w') as f:
                np.lib.format.write_array(f, np.asarray(arr), allow_pickle=False)
    progress.close()
    return {'agents': n_agents, 'steps': steps}
