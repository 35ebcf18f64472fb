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
from typing import Any
import zipfile

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.accuracy import radius68
from gps_error_ros.model.atomic import atomic_output, PathArg
from gps_error_ros.model.motion_lag import LagBuffer
from gps_error_ros.model.protocol import ErrorModel, S
from gps_error_ros.model.reported import needs_predictive, ReportedAccuracy
from gps_error_ros.model.state import BoolArray, FloatArray, Numbers
from gps_error_ros.model.velocity import Velocity
from gps_error_ros.model.zoned import TravelDirections, ZoneSetup
from gps_error_ros.sim.crowd import CrowdErrors
from gps_error_ros.sim.faults import Fault, FaultOverlay, FixRows
from gps_error_ros.sim.trajectory_fixes import (accuracy_columns, agent_names, model_step,
                                                per_fix, stated_accuracy, trajectory_fixes)
from gps_error_ros.sim.velocity_sim import StreamedVelocity
from gps_error_ros.traces.progress import Progress
from gps_error_ros.traces.nmea_write import epoch_sentences
from gps_error_ros.traces.trace_io import Trace, write_trace_csv
from gps_error_ros.traces.trajectories import (
    add_errors_lonlat, check_fcd_root, fcd_coordinates, fcd_net_file, FcdWriter, iter_fcd,
    NetProjection, read_truth_csv, TrajectoryError)


def simulate_fcd(src: PathArg, dst: PathArg, model: ErrorModel[S], rate_hz: float, seed: int,
                 net: PathArg | None = None, coordinates: str | None = None,
                 digits: int | None = None, zones: ZoneSetup | None = None,
                 covariance_mode: str = 'stationary', reported: ReportedAccuracy | None = None,
                 velocity: Velocity | None = None,
                 reported_bias: Numbers | None = None,
                 faults: Sequence[Fault] = ()) -> dict[str, int]:
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
    """
    with atomic_output(dst) as tmp:
        return _simulate_fcd(src, tmp, model, rate_hz, seed, net, coordinates, digits,
                             zones, covariance_mode, reported, velocity, reported_bias, faults)


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


def _fcd_mode(src: PathArg, net: PathArg | None,
              coordinates: str | None) -> tuple[str, NetProjection | None]:
    """
    Return how to move an FCD file's positions: 'lonlat', 'net' or 'plane'.

    Never guessed from the values: SUMO writes its options in a comment at
    the top of the file (``fcd-output.geo`` there means lon/lat); a file
    without that comment needs ``coordinates`` ('lonlat' or 'xy').
    """
    check_fcd_root(src)
    mode = coordinates or fcd_coordinates(src)
    if mode is None:
        raise TrajectoryError(
            f'{src}: no SUMO options comment at the top, so whether x/y are '
            f'lon/lat or metres is unknown: pass --coordinates lonlat or xy')
    if mode == 'lonlat':
        _check_geo_output(src, net)
        return 'lonlat', None
    if net is None:
        raise TrajectoryError(
            f'{src}: positions are x/y metres of the network (SUMO ran without '
            f'--fcd-output.geo): pass --net NET.xml to georeference them')
    proj = NetProjection(net)
    return ('net' if proj.geo else 'plane'), proj


def _check_geo_output(src: PathArg, net: PathArg | None) -> None:
    """
    Refuse lon/lat that SUMO could not write: ``--fcd-output.geo`` from a net with no projection.

    SUMO then warns that geo output will not work and writes x/y metres
    anyway. The net given (``--net``) or named in the options comment tells.
    """
    net = net or fcd_net_file(src)
    if net is None or NetProjection(net).geo:
        return
    raise TrajectoryError(
        f'{src}: the options comment says --fcd-output.geo, but the network {net} has '
        f'no projection (its <location> projParameter is "!"), so SUMO wrote x/y metres, '
        f'not lon/lat (it warns "fcd-output.geo will not work"): give the network a '
        f'projection (netgenerate/netconvert --proj "+proj=utm ..." or --proj.utm), or '
        f'read the positions as a flat plane with --coordinates xy --net {net}')


def _lonlat(mode: str, proj: NetProjection | None, x: Numbers,
            y: Numbers) -> tuple[FloatArray, FloatArray]:
    """Return FCD positions as (lon, lat) arrays (mode 'lonlat' or 'net')."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if mode == 'lonlat':
        return x, y
    lon, lat = _net(proj).to_lonlat(x, y)
    return np.asarray(lon), np.asarray(lat)


def _net(proj: NetProjection | None) -> NetProjection:
    """Return the network's projection of modes 'net' and 'plane' (which always have one)."""
    if proj is None:
        raise TrajectoryError('FCD x/y metres need the network\'s projection (--net NET.xml)')
    return proj


def _moved(mode: str, proj: NetProjection | None, src: PathArg, t: float, x: Numbers,
           y: Numbers, err: FloatArray) -> tuple[Any, Any, str]:
    """Return the positions moved by ``err`` and their number format."""
    if mode == 'lonlat':
        if np.any(np.abs(y) > 90) or np.any(np.abs(x) > 180):
            raise TrajectoryError(f'{src}: time {t}: x/y outside lon/lat ranges, '
                                  f'but the file says (or you said) lon/lat')
        return (*add_errors_lonlat(x, y, err), '{:.8f}')
    if mode == 'net':
        net = _net(proj)
        lon, lat = net.to_lonlat(x, y)
        return (*net.to_xy(*add_errors_lonlat(lon, lat, err)), '{:.3f}')
    return x + err[:, 1], y + err[:, 0], '{:.3f}'


def _simulate_fcd(src: PathArg, dst: PathArg, model: ErrorModel[S], rate_hz: float, seed: int,
                  net: PathArg | None = None, coordinates: str | None = None,
                  digits: int | None = None, zones: ZoneSetup | None = None,
                  covariance_mode: str = 'stationary', reported: ReportedAccuracy | None = None,
                  velocity: Velocity | None = None,
                  reported_bias: Numbers | None = None,
                  faults: Sequence[Fault] = ()) -> dict[str, int]:
    """
    Add errors to every agent of a SUMO FCD file; return counts.

    Long because it is one streaming pass over the file's timesteps, each
    step's columns made in the order they depend on each other.
    """
    mode, proj = _fcd_mode(src, net, coordinates)
    conditional = needs_predictive(covariance_mode, reported)
    stated = stated_accuracy(covariance_mode, model, reported, seed, reported_bias)
    zones = per_fix(model, zones, conditional)
    stationary = np.asarray(model.stationary_cov)
    _check_georeferenced(src, zones, mode)
    progress = Progress(os.path.getsize(src), f'simulating {Path(src).name}', min_total=20 << 20)
    writer = FcdWriter(dst)
    crowd: CrowdErrors | None = None
    rows, steps, no_fix = 0, 0, 0
    seen: set[str] = set()
    lag = LagBuffer(model.lag_s)
    travel = TravelDirections(model.lag_s)
    vel = None if velocity is None else StreamedVelocity(velocity, seed, mode == 'plane')
    overlay = _fcd_overlay(src, faults, mode, seed)
    try:
        for t, elem, agents in iter_fcd(src, progress):
            m = model_step(t, rate_hz)
            if crowd is None:
                crowd = CrowdErrors(model, seed, m, conditional_cov=conditional, zoned=zones)
            crowd.advance_to(m)
            steps += 1
            if not agents:
                writer.timestep(elem, [])
                continue
            names = [a[0] for a in agents]
            seen.update(names)
            x, y = lag.lagged(names, t, [a[1] for a in agents], [a[2] for a in agents])
            if zones is None:
                err = crowd.errors(names)
                cov = crowd.covariance(names) if conditional else \
                    np.repeat(stationary[None], len(names), axis=0)
            else:
                lon, lat = _lonlat(mode, proj, x, y)
                raw_lon, raw_lat = _lonlat(mode, proj, [a[1] for a in agents],
                                           [a[2] for a in agents])
                heading = travel.directions(names, t, raw_lat, raw_lon)
                err, cov = crowd.zoned_errors(names, lat, lon, heading)
            nx, ny, fmt = _moved(mode, proj, src, t, x, y, err)
            fmt = fmt if digits is None else f'{{:.{digits}f}}'
            fix = crowd.available(names)        # in an outage: no position written
            radius, cov = stated.streamed(names, m, cov) if stated else (None, cov)
            speeds = {} if vel is None else _fcd_velocity(vel, mode, proj, names, t, m, agents)
            if overlay is not None:
                nx, ny, fix, cov, radius = _fcd_faults(overlay, mode, proj, t, names, x, y,
                                                       err, fix, cov, radius, speeds, (nx, ny))
            acc = {k: (v, '{:.3f}') for k, v in accuracy_columns(cov, fix, radius).items()}
            acc.update(speeds)
            cols = {k: formatted(*vf) for k, vf in {'x': (nx, fmt), 'y': (ny, fmt), **acc}.items()}
            writer.timestep(elem, [
                (a[3], {k: v for k, c in cols.items() if (v := c[i]) is not None})
                for i, a in enumerate(agents) if fix[i]])
            rows += int(fix.sum())
            no_fix += int((~fix).sum())
    finally:
        writer.close()
        progress.close()
    return _fcd_counts(src, model, steps, rows, len(seen), no_fix, overlay is not None)


def _fcd_overlay(src: PathArg, faults: Sequence[Fault], mode: str,
                 seed: int) -> FaultOverlay | None:
    """Return the faults' overlay (None without faults); refuse them on a flat plane."""
    if not faults:
        return None
    if mode == 'plane':
        raise TrajectoryError(f'{src}: faults need longitude and latitude, and the network '
                              f'has no geo-reference (no projection in its <location>)')
    return FaultOverlay(faults, seed)


def _fcd_faults(overlay: FaultOverlay, mode: str, proj: NetProjection | None, t: float,
                names: Sequence[str], x: Numbers, y: Numbers, err: FloatArray, fix: BoolArray,
                cov: FloatArray, radius: FloatArray | None,
                speeds: dict[str, tuple[FloatArray, str]], moved: tuple[Any, Any]
                ) -> tuple[Any, Any, BoolArray, FloatArray, FloatArray | None]:
    """
    Lay the faults over one FCD timestep; return its x, y, fix, covariance and radius.

    ``x``, ``y``: the (lagged) truth the errors were added to; ``moved``
    the positions with the errors; ``speeds`` (the reported velocity's
    columns) are changed in place for a frozen receiver.
    """
    lon, lat = _lonlat(mode, proj, x, y)
    mlon, mlat = add_errors_lonlat(lon, lat, err)
    rows = FixRows(int(round(t * 1e9)), overlay.ids_of(names),
                   streams.agent_keys(overlay.seed, names), lat, lon, mlat, mlon,
                   np.zeros(len(names)), err.copy(), fix.copy(), cov.copy(),
                   {k: v[0] for k, v in speeds.items()})
    touched = overlay.apply(rows)
    if not touched.any():
        return (*moved, fix, cov, radius)
    if radius is not None:
        radius = np.array(radius, dtype=float)
        radius[touched] = radius68(rows.cov[touched])
    nx, ny = (rows.lon, rows.lat) if mode == 'lonlat' else _net(proj).to_xy(rows.lon, rows.lat)
    return nx, ny, rows.fix, rows.cov, radius


def _fcd_counts(src: PathArg, model: ErrorModel[S], steps: int, rows: int, agents: int,
                no_fix: int, faults: bool = False) -> dict[str, int]:
    """Return what simulate_fcd did; refuse a file in which nobody moved."""
    if not agents:
        raise TrajectoryError(f'{src}: {steps} timesteps and no person or vehicle in any: '
                              f'expected positions to add errors to (did SUMO fail or end '
                              f'before anyone departed?)')
    out = {'timesteps': steps, 'positions': rows, 'agents': agents}
    if model.has_outages or faults:
        out['positions_without_fix'] = no_fix
    return out


def formatted(values: Numbers, fmt: str) -> Sequence[str | None]:
    """
    Return ``values`` as strings in ``fmt`` ('{:.Nf}'), None where not finite.

    One %-format over the whole array (done in C) instead of a call per
    value: the same digits, at a fraction of the cost for a crowd's
    timestep.
    """
    values = np.asarray(values, dtype=float)
    ok = np.isfinite(values)
    digits = re.fullmatch(r'\{:\.(\d+)f\}', fmt)
    if digits is None:
        return [fmt.format(v) if o else None for v, o in zip(values.tolist(), ok.tolist())]
    text = ('\x1f'.join([f'%.{digits.group(1)}f'] * values.size)
            % tuple(values.tolist())).split('\x1f') if values.size else []
    if ok.all():
        return text
    return [v if o else None for v, o in zip(text, ok.tolist())]


def _fcd_velocity(vel: StreamedVelocity, mode: str, proj: NetProjection | None,
                  names: Sequence[str], t: float, step: int,
                  agents: Sequence[Sequence[Any]]) -> dict[str, tuple[FloatArray, str]]:
    """Return the reported_speed and reported_bearing attributes (values, format)."""
    x, y = [a[1] for a in agents], [a[2] for a in agents]
    if mode == 'plane':
        speed, course = vel.report(names, t, step, np.asarray(y, float), np.asarray(x, float))
    else:
        lon, lat = _lonlat(mode, proj, x, y)
        speed, course = vel.report(names, t, step, lat, lon)
    return {'reported_speed': (speed, '{:.3f}'), 'reported_bearing': (course, '{:.2f}')}


def _check_georeferenced(src: PathArg, zones: ZoneSetup | None, mode: str) -> None:
    """Refuse zones (or a street frame) on FCD metres without a geo-reference."""
    if zones is not None and mode == 'plane':
        raise TrajectoryError(f'{src}: the network has no geo-reference (no projection in '
                              f'its <location>), so positions cannot be placed in the '
                              f'zone map\'s longitude/latitude polygons or give a '
                              f'direction of travel for street_frame')


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
