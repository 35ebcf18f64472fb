"""
One FCD timestep's noisy columns, shared by the XML and the Parquet paths of ``simulate``.

:class:`FcdSteps` holds what a pass over an FCD file carries from one
timestep to the next (the crowd's errors, the motion lag's truth, the
directions of travel, the reported velocity, the faults) and turns one
timestep's agents (names and true x/y) into numbers: the moved positions,
which agents have a fix, the stated accuracy and the reported velocity. The
XML path formats them into attributes, the Parquet path into columns; both
call :meth:`FcdSteps.timestep`, so the same file gives the same errors in
either format, bit for bit.
"""

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Generic, Optional

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.accuracy import radius68
from gps_error_ros.model.atomic import PathArg
from gps_error_ros.model.motion_lag import LagBuffer
from gps_error_ros.model.protocol import ErrorModel, S
from gps_error_ros.model.reported import needs_predictive, ReportedAccuracy
from gps_error_ros.model.state import BoolArray, FloatArray, IntArray, Numbers
from gps_error_ros.model.velocity import Velocity
from gps_error_ros.model.zoned import TravelDirections, ZoneSetup
from gps_error_ros.sim.crowd import CrowdErrors
from gps_error_ros.sim.faults import Fault, FaultOverlay, FixRows
from gps_error_ros.sim.trajectory_fixes import (accuracy_columns, model_step, per_fix,
                                                stated_accuracy)
from gps_error_ros.sim.velocity_sim import StreamedVelocity
from gps_error_ros.traces.trajectories import (add_errors_lonlat, check_fcd_root,
                                               fcd_coordinates, fcd_net_file, NetProjection,
                                               TrajectoryError)


#: Moved positions: x, y, and (lon, lat) where x/y are a georeferenced network's metres.
Moved = tuple[Any, Any, Optional[tuple[FloatArray, FloatArray]]]


@dataclass(frozen=True)
class FcdOptions:
    """
    What ``simulate`` was asked to do with an FCD file, whatever its format.

    ``mode``: how positions are moved, 'lonlat' (x/y are longitude and
    latitude), 'net' (x/y metres of a georeferenced network, ``proj``) or
    'plane' (x/y metres of a network with no projection).
    """

    mode: str
    proj: NetProjection | None
    rate_hz: float
    seed: int
    covariance_mode: str = 'stationary'
    zones: ZoneSetup | None = None
    reported: ReportedAccuracy | None = None
    velocity: Velocity | None = None
    reported_bias: Numbers | None = None
    faults: Sequence[Fault] = ()


@dataclass(frozen=True)
class FcdRequest(Generic[S]):
    """
    What ``simulate`` is asked to do with a Parquet FCD file or its parts, in one record.

    ``net`` and ``coordinates`` say how x/y are read (they become
    :class:`FcdOptions`' ``mode`` and ``proj`` once the file is seen);
    ``errors``: also write each position's north/east error. The rest are
    :func:`~gps_error_ros.sim.simulate.simulate_fcd`'s options.
    """

    model: ErrorModel[S]
    rate_hz: float
    seed: int
    net: str | None = None
    coordinates: str | None = None
    zones: ZoneSetup | None = None
    covariance_mode: str = 'stationary'
    reported: ReportedAccuracy | None = None
    velocity: Velocity | None = None
    reported_bias: Numbers | None = None
    faults: Sequence[Fault] = ()
    errors: bool = False

    def options(self, mode: str, proj: NetProjection | None) -> FcdOptions:
        """Return the options of the step, positions moved as ``mode`` says."""
        return FcdOptions(mode, proj, self.rate_hz, self.seed, self.covariance_mode,
                          self.zones, self.reported, self.velocity, self.reported_bias,
                          self.faults)


@dataclass
class FcdColumns:
    """
    One timestep's noisy positions and what goes with them, one row per agent.

    ``x``, ``y``: the positions moved by the errors, in the file's own
    coordinates; ``fix``: False in an outage (no position is written);
    ``accuracy``: the stated-accuracy columns (NaN without a fix);
    ``velocity``: ``reported_speed`` and ``reported_bearing`` with a
    profile's velocity; ``error``: the north and east error of each
    position written (m, (n, 2)); ``lonlat``: the moved positions'
    longitude and latitude where x/y are a georeferenced network's metres
    (else None); ``metres``: whether x/y are metres (else degrees).
    """

    x: FloatArray
    y: FloatArray
    fix: BoolArray
    accuracy: dict[str, FloatArray]
    velocity: dict[str, FloatArray]
    error: FloatArray
    lonlat: tuple[FloatArray, FloatArray] | None
    metres: bool
    #: False when ``x``, ``y`` are still the (lagged) truth: :meth:`FcdSteps.move` moves them
    moved: bool = True


class FcdSteps(Generic[S]):
    """
    A pass over one FCD file's timesteps, in order (see the module doc).

    Parameters
    ----------
    src
        The file, named in errors.
    model
        The profile's model.
    options
        The run's options.
    start_step
        The run's first model step; None: the first timestep's. A file
        split by agent gives every part the whole file's first step, so
        that each agent gets the errors of the whole run.

    """

    def __init__(self, src: PathArg, model: ErrorModel[S], options: FcdOptions,
                 start_step: int | None = None) -> None:
        self.src = src
        self.model = model
        self.o = options
        self.conditional = needs_predictive(options.covariance_mode, options.reported)
        self.stated = stated_accuracy(options.covariance_mode, model, options.reported,
                                      options.seed, options.reported_bias)
        self.zones = per_fix(model, options.zones, self.conditional)
        self.stationary = np.asarray(model.stationary_cov)
        if self.zones is not None and options.mode == 'plane':
            raise TrajectoryError(
                f'{src}: the network has no geo-reference (no projection in its '
                f'<location>), so positions cannot be placed in the zone map\'s '
                f'longitude/latitude polygons or give a direction of travel for '
                f'street_frame')
        if options.faults and options.mode == 'plane':
            raise TrajectoryError(f'{src}: faults need longitude and latitude, and the '
                                  f'network has no geo-reference (no projection in its '
                                  f'<location>)')
        self.start = start_step
        self.crowd: CrowdErrors[S] | None = None
        self.lag = LagBuffer(model.lag_s)
        self.travel = TravelDirections(model.lag_s)
        self.vel = None if options.velocity is None else \
            StreamedVelocity(options.velocity, options.seed, options.mode == 'plane')
        self.overlay = FaultOverlay(options.faults, options.seed) if options.faults else None

    def timestep(self, t: float, names: Sequence[str], x: Numbers, y: Numbers,
                 coded: Optional[tuple[Sequence[str], IntArray]] = None,
                 defer: bool = False) -> FcdColumns:
        """
        Return the noisy columns of one timestep's agents (true ``x``, ``y``).

        The run starts at the first timestep with an agent (or at
        ``start_step``): a timestep with nobody in it moves nothing.
        ``coded``: the names as (dictionary, codes), ``names`` being
        ``dictionary[codes]``: a table's column looks each name up once.
        ``defer``: leave the positions unmoved where no fault can touch them
        (``moved`` False), for :meth:`move` to move many timesteps at once.
        """
        m = model_step(t, self.o.rate_hz)
        raw_x, raw_y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        if not len(names):
            empty = np.zeros(0)
            return FcdColumns(empty, empty, np.zeros(0, dtype=bool), {}, {},
                              np.zeros((0, 2)), None, self.o.mode != 'lonlat')
        if self.crowd is None:
            self.crowd = CrowdErrors(self.model, self.o.seed,
                                     m if self.start is None else self.start,
                                     conditional_cov=self.conditional, zoned=self.zones)
        crowd = self.crowd
        crowd.advance_to(m)
        lx, ly = self.lag.lagged(names, t, raw_x, raw_y)
        rows = self._rows(names, coded)
        generation = crowd.generation
        if self.zones is None:
            err = crowd.errors(names, rows)
            if crowd.generation != generation:     # agents long unseen were dropped
                rows = self._rows(names, coded)
            cov = crowd.covariance(names, rows) if self.conditional else \
                np.repeat(self.stationary[None], len(names), axis=0)
        else:
            lon, lat = self._lonlat(lx, ly)
            raw_lon, raw_lat = self._lonlat(raw_x, raw_y)
            heading = self.travel.directions(names, t, raw_lat, raw_lon)
            err, cov = crowd.zoned_errors(names, lat, lon, heading, rows)
            if crowd.generation != generation:
                rows = self._rows(names, coded)
        lx, ly = np.asarray(lx, dtype=float), np.asarray(ly, dtype=float)
        later = defer and self.overlay is None
        moved: Moved = (lx, ly, None) if later else self._moved(t, lx, ly, err)
        fix = crowd.available(names, rows)
        radius, cov = self.stated.streamed(names, m, cov, crowd.start) if self.stated \
            else (None, cov)
        speeds = {} if self.vel is None else self._velocity(names, t, m, crowd.start, raw_x,
                                                            raw_y)
        if self.overlay is not None:
            moved, fix, cov, radius, err = self._faults(t, names, lx, ly, err, fix, cov,
                                                        radius, speeds, moved)
        nx, ny, geo = moved
        return FcdColumns(np.asarray(nx, dtype=float), np.asarray(ny, dtype=float), fix,
                          accuracy_columns(cov, fix, radius), speeds, err, geo,
                          self.o.mode != 'lonlat', not later)

    def move(self, t: FloatArray, x: FloatArray, y: FloatArray, err: FloatArray) -> Moved:
        """
        Return positions (rows of several timesteps, times ``t``) moved by ``err``.

        What :meth:`timestep` does to one timestep's positions, row by row,
        so the same rows give the same doubles however they are grouped.
        """
        return self._moved(t, x, y, err)

    def _rows(self, names: Sequence[str],
              coded: Optional[tuple[Sequence[str], IntArray]]) -> IntArray:
        """Return the crowd's rows of ``names`` (by their codes when given)."""
        assert self.crowd is not None
        return self.crowd.rows(names) if coded is None else self.crowd.coded_rows(*coded)

    def _lonlat(self, x: Numbers, y: Numbers) -> tuple[FloatArray, FloatArray]:
        """Return positions as (lon, lat) arrays (mode 'lonlat' or 'net')."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        if self.o.mode == 'lonlat':
            return x, y
        lon, lat = self._net().to_lonlat(x, y)
        return np.asarray(lon), np.asarray(lat)

    def _net(self) -> NetProjection:
        """Return the network's projection (modes 'net' and 'plane' always have one)."""
        if self.o.proj is None:
            raise TrajectoryError('FCD x/y metres need the network\'s projection (--net NET.xml)')
        return self.o.proj

    def _moved(self, t: float | FloatArray, x: FloatArray, y: FloatArray,
               err: FloatArray) -> Moved:
        """Return the positions moved by ``err``, and their lon/lat in mode 'net'."""
        if self.o.mode == 'lonlat':
            out = (np.abs(y) > 90) | (np.abs(x) > 180)
            if np.any(out):
                at = t if np.ndim(t) == 0 else np.asarray(t)[np.flatnonzero(out)[0]]
                raise TrajectoryError(f'{self.src}: time {float(at)}: x/y outside lon/lat '
                                      f'ranges, but the file says (or you said) lon/lat')
            return (*add_errors_lonlat(x, y, err), None)
        if self.o.mode == 'net':
            net = self._net()
            lon, lat = net.to_lonlat(x, y)
            geo = add_errors_lonlat(lon, lat, err)
            return (*net.to_xy(*geo), geo)
        return x + err[:, 1], y + err[:, 0], None

    def _velocity(self, names: Sequence[str], t: float, step: int, start: int, x: FloatArray,
                  y: FloatArray) -> dict[str, FloatArray]:
        """Return the reported_speed and reported_bearing columns (streams from ``start``)."""
        assert self.vel is not None
        if self.o.mode == 'plane':
            speed, course = self.vel.report(names, t, step, y, x, start)
        else:
            lon, lat = self._lonlat(x, y)
            speed, course = self.vel.report(names, t, step, lat, lon, start)
        return {'reported_speed': speed, 'reported_bearing': course}

    def _faults(self, t: float, names: Sequence[str], x: Numbers, y: Numbers,
                err: FloatArray, fix: BoolArray, cov: FloatArray, radius: FloatArray | None,
                speeds: dict[str, FloatArray], moved: Moved
                ) -> tuple[Moved, BoolArray, FloatArray, FloatArray | None, FloatArray]:
        """
        Lay the faults over one timestep; return its positions, fix, covariance, radius, error.

        ``x``, ``y``: the (lagged) truth the errors were added to; ``moved``
        the positions with the errors; ``speeds`` (the reported velocity's
        columns) are changed in place for a frozen receiver.
        """
        assert self.overlay is not None
        lon, lat = self._lonlat(x, y)
        mlon, mlat = add_errors_lonlat(lon, lat, err)
        rows = FixRows(int(round(t * 1e9)), self.overlay.ids_of(names),
                       streams.agent_keys(self.overlay.seed, names), lat, lon, mlat, mlon,
                       np.zeros(len(names)), err.copy(), fix.copy(), cov.copy(), speeds)
        touched = self.overlay.apply(rows)
        if not touched.any():
            return moved, fix, cov, radius, err
        if radius is not None:
            radius = np.array(radius, dtype=float)
            radius[touched] = radius68(rows.cov[touched])
        if self.o.mode == 'lonlat':
            out: Moved = (rows.lon, rows.lat, None)
        else:
            out = (*self._net().to_xy(rows.lon, rows.lat), (rows.lon, rows.lat))
        return out, rows.fix, rows.cov, radius, rows.error


def position_mode(src: PathArg, coordinates: str,
                  net: PathArg | None) -> tuple[str, NetProjection | None]:
    """
    Return how to move a file's positions, 'lonlat', 'net' or 'plane', and the net's projection.

    ``coordinates``: what the file's x/y are, 'lonlat' or 'xy' (metres of
    the network ``net``). Lon/lat from a network without a projection are
    refused: SUMO then writes metres in spite of ``--fcd-output.geo``.
    """
    if coordinates == 'lonlat':
        if net is not None and not NetProjection(net).geo:
            raise TrajectoryError(
                f'{src}: the positions are said to be lon/lat (--fcd-output.geo), but the '
                f'network {net} has no projection (its <location> projParameter is "!"), '
                f'so SUMO wrote x/y metres, not lon/lat (it warns "fcd-output.geo will not '
                f'work"): give the network a projection (netgenerate/netconvert --proj '
                f'"+proj=utm ..." or --proj.utm), or read the positions as a flat plane '
                f'with --coordinates xy --net {net}')
        return 'lonlat', None
    if net is None:
        raise TrajectoryError(
            f'{src}: positions are x/y metres of the network (SUMO ran without '
            f'--fcd-output.geo): pass --net NET.xml to georeference them')
    proj = NetProjection(net)
    return ('net' if proj.geo else 'plane'), proj


def xml_position_mode(src: PathArg, net: PathArg | None,
                      coordinates: str | None) -> tuple[str, NetProjection | None]:
    """
    Return how to move an FCD XML file's positions, as :func:`position_mode`.

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
    return position_mode(src, mode, net or (fcd_net_file(src) if mode == 'lonlat' else None))


def fcd_counts(src: PathArg, model: ErrorModel[S], steps: int, rows: int, agents: int,
               no_fix: int, faults: bool = False) -> dict[str, int]:
    """Return what a pass over an FCD file did; refuse a file in which nobody moved."""
    if not agents:
        raise TrajectoryError(f'{src}: {steps} timesteps and no person or vehicle in any: '
                              f'expected positions to add errors to (did SUMO fail or end '
                              f'before anyone departed?)')
    out = {'timesteps': steps, 'positions': rows, 'agents': agents}
    if model.has_outages or faults:
        out['positions_without_fix'] = no_fix
    return out
