"""
The fixes of trajectories, in memory: what ``simulate``'s CSV mode writes.

:func:`trajectory_fixes` gives every row of a table of true positions its
fix as the error node would (the agents' streams, zones, the stated
accuracy, the reported velocity and faults on demand), before any file is
written: :mod:`~gps_error_ros.sim.simulate` writes it, and the public API
(:func:`gps_error_ros.api.add_errors`) returns it.
"""

from collections.abc import Mapping, Sequence
import math
from typing import Any

import numpy as np

from gps_error_ros.model.accuracy import ellipse, radius68
from gps_error_ros.model.atomic import PathArg
from gps_error_ros.model.motion_lag import LagBuffer
from gps_error_ros.model.protocol import ErrorModel, opaque, S
from gps_error_ros.model.reported import needs_predictive, reference_cov, ReportedAccuracy
from gps_error_ros.model.state import BoolArray, FloatArray, Numbers
from gps_error_ros.model.velocity import Velocity
from gps_error_ros.model.stepping import StepsPerFix
from gps_error_ros.model.zoned import TravelDirections, ZoneSetup
from gps_error_ros.sim.crowd import CrowdErrors
from gps_error_ros.sim.faults import Fault, FaultOverlay, FixRows, lay_over_rows
from gps_error_ros.sim.velocity_sim import row_values, speed_and_course, StreamTracker
from gps_error_ros.traces.trajectories import add_errors_lonlat, TrajectoryError


def per_fix(model: ErrorModel[S], zones: ZoneSetup | None,
            conditional: bool = False) -> ZoneSetup | None:
    """Return ``zones``, or the agents stepped per fix of a street-frame model, or None."""
    if zones is None and model.needs_heading:
        return None, StepsPerFix(opaque(model), conditional_cov=conditional)
    return zones


def model_step(t: float, rate_hz: float) -> int:
    """Return the model step containing time ``t`` (s)."""
    return int(math.floor(t * rate_hz + 1e-9))


def trajectory_fixes(data: Mapping[str, Any], model: ErrorModel[S], rate_hz: float,
                     seed: int, velocity: Velocity | None = None,
                     covariance_mode: str = 'stationary', zones: ZoneSetup | None = None,
                     reported: ReportedAccuracy | None = None,
                     reported_bias: Numbers | None = None, faults: Sequence[Fault] = (),
                     src: str = 'trajectories') -> tuple[FixRows, FloatArray | None]:
    """
    Return the fixes of true positions ``data`` (``t``, ``agent``, ``truth_lat``, ``truth_lon``).

    The rows of :func:`simulate_csv` before they are written: the
    :class:`~gps_error_ros.sim.faults.FixRows` (``extra`` holds ``speed``,
    ``bearing``, ``truth_speed`` and ``truth_bearing`` with ``velocity``, NaN
    without a fix) and the stated 68 % radius in covariance mode
    ``reported`` (else None: the covariance's own).
    """
    t = data['t']
    if np.any(np.diff(t) < 0):
        back = int(np.flatnonzero(np.diff(t) < 0)[0]) + 1
        raise TrajectoryError(
            f'{src}: t must be non-decreasing, row {back} goes back from {t[back - 1]:g} s '
            f'to {t[back]:g} s: sort the rows of all agents together by time (the agent '
            f'column says whose row it is), not agent by agent')
    conditional = needs_predictive(covariance_mode, reported)
    rows = _csv_rows(src, data, model, rate_hz, seed, conditional,
                     per_fix(model, zones, conditional))
    radius = None
    if covariance_mode == 'reported':
        stated = Stated(model, reported, seed, reported_bias)
        radius, rows.cov = stated.radius(row_values(stated.reported, seed, data['agent'], t,
                                                    model_step(t[0], rate_hz), rate_hz),
                                         rows.cov)
    if velocity is not None:
        cols = speed_and_course(velocity, seed, data, model_step(t[0], rate_hz), rate_hz)
        rows.extra.update(zip(('speed', 'bearing', 'truth_speed', 'truth_bearing'), cols))
    if faults:
        touched = lay_over_rows(FaultOverlay(faults, seed), t, data['agent'], rows)
        if radius is not None:
            radius[touched] = radius68(rows.cov[touched])
    if velocity is not None:
        for k in ('speed', 'bearing'):
            rows.extra[k][~rows.fix] = np.nan             # no fix: nothing reported
    return rows, radius


def _csv_rows(src: PathArg, data: Mapping[str, Any], model: ErrorModel[S], rate_hz: float,
              seed: int, conditional: bool, zones: ZoneSetup | None) -> FixRows:
    """
    Return the fixes of every row of a truth CSV (``stamp_ns`` unused: rows of many times).

    ``truth_lat``/``truth_lon`` are the positions the errors were added to
    (the truth ``lag_s`` earlier with a motion lag).
    """
    t = data['t']
    crowd = CrowdErrors(model, seed, model_step(t[0], rate_hz), conditional_cov=conditional,
                        zoned=zones)
    lag = LagBuffer(model.lag_s)
    travel = TravelDirections(model.lag_s)
    rows = FixRows(0, np.zeros(t.size, dtype=np.int64), np.zeros(t.size, dtype=np.uint64),
                   np.empty_like(t), np.empty_like(t), np.empty_like(t), np.empty_like(t),
                   np.zeros_like(t), np.empty((t.size, 2)), np.ones(t.size, dtype=bool),
                   np.repeat(np.asarray(model.stationary_cov)[None], t.size, axis=0))
    bounds = np.flatnonzero(np.r_[True, np.diff(t) > 0, True])
    for b0, b1 in zip(bounds[:-1], bounds[1:]):
        crowd.advance_to(model_step(t[b0], rate_hz))
        names = data['agent'][b0:b1]
        if len(set(names)) != len(names):
            raise TrajectoryError(f'{src}: agent listed twice at t={t[b0]}')
        lon, lat = lag.lagged(names, t[b0], data['truth_lon'][b0:b1],
                              data['truth_lat'][b0:b1])
        if zones is not None:
            heading = travel.directions(names, t[b0], data['truth_lat'][b0:b1],
                                        data['truth_lon'][b0:b1])
            err, rows.cov[b0:b1] = crowd.zoned_errors(names, lat, lon, heading)
        else:
            err = crowd.errors(names)
            if conditional:
                rows.cov[b0:b1] = crowd.covariance(names)
        rows.fix[b0:b1] = crowd.available(names)
        rows.error[b0:b1] = err
        rows.truth_lat[b0:b1], rows.truth_lon[b0:b1] = lat, lon
        rows.lon[b0:b1], rows.lat[b0:b1] = add_errors_lonlat(lon, lat, err)
    # a row in an outage: status no_fix and no position (read back as a gap)
    rows.lat[~rows.fix] = rows.lon[~rows.fix] = np.nan
    return rows


def stated_accuracy(covariance_mode: str, model: ErrorModel[S],
                    reported: ReportedAccuracy | None, seed: int,
                    bias: Numbers | None) -> 'Stated | None':
    """Return the :class:`Stated` radius of covariance_mode reported, else None."""
    return Stated(model, reported, seed, bias) if covariance_mode == 'reported' else None


class Stated:
    """The radius a profile's ``reported_accuracy`` states, for covariance_mode reported."""

    def __init__(self, model: ErrorModel[S], reported: ReportedAccuracy | None, seed: int,
                 bias: Numbers | None = None) -> None:
        if reported is None:
            raise TrajectoryError('covariance mode reported: the profile has no '
                                  'reported_accuracy section (calibrate one from a trace '
                                  'with an accuracy or hdop column)')
        self.reported, self.seed, self.bias = reported, seed, bias
        self.ref_cov = reference_cov(model) if reported.follow != 0.0 else None
        self.tracker: StreamTracker | None = None

    def streamed(self, names: Sequence[str], step: int, cov: FloatArray,
                 start: int | None = None) -> tuple[FloatArray, FloatArray]:
        """
        Return :meth:`radius` of agents streamed step by step.

        Their streams count from the run's first model step ``start``
        (default: the step of the first call).
        """
        if self.tracker is None:
            self.tracker = StreamTracker(self.reported, self.seed,
                                         step if start is None else start)
        return self.radius(self.tracker.values(names, step), cov)

    def radius(self, x: Numbers, cov: FloatArray | None) -> tuple[FloatArray, FloatArray]:
        """Return (stated radius, the covariance it implies) for fluctuations ``x``."""
        r = self.reported.radius(x, cov, self.ref_cov)
        return r, self.reported.covariance(r, self.bias)


def accuracy_columns(cov: FloatArray, fix: BoolArray,
                     radius: Numbers | None = None) -> dict[str, FloatArray]:
    """
    Return the stated-accuracy columns of north/east covariances (NaN without a fix).

    ``radius``: the stated 68 % radius when the phone states it (else the
    covariance's own).
    """
    flat = cov.reshape(-1, 4)
    if flat.shape[0] > 1 and (flat == flat[0]).all():    # one covariance for all (stationary)
        key = flat[0].tobytes()
        one = _ONE.get(key)
        if one is None:
            if len(_ONE) > 1024:
                _ONE.clear()
            one = _ONE[key] = {k: float(v[0]) for k, v in
                               accuracy_columns(cov[:1], np.ones(1, dtype=bool)).items()}
        cols = {k: np.full(flat.shape[0], v) for k, v in one.items()}
        if radius is not None:
            cols['accuracy'] = np.array(radius, dtype=float)
    else:
        major, minor, orientation = ellipse(cov)
        cols = {'accuracy': radius68(cov) if radius is None else np.array(radius, dtype=float),
                'accuracy_major': major, 'accuracy_minor': minor,
                'accuracy_orientation': orientation}
    if not fix.all():
        miss = ~fix
        for v in cols.values():
            v[miss] = np.nan
    return cols


#: The columns of one covariance shared by a whole timestep, by its bytes: a crowd in
#: stationary mode has one covariance for the run.
_ONE: dict[bytes, dict[str, float]] = {}


def agent_names(n: int, prefix: str = 'agent') -> list[str]:
    """Return the agent names used by ``--agents N``."""
    return [f'{prefix}{i}' for i in range(n)]
