"""
A phone's GPS in ns-3: each node's true position plus its agent's errors.

:class:`GpsSource` reads every node's true position from its ns-3
``MobilityModel`` (ns-3's own models, an ns-2 mobility trace through
``Ns2MobilityHelper``, or waypoints from SUMO's FCD) once per GPS epoch. It
adds that agent's errors and writes the fix where ns-3 applications read it
(``gps_error_ns3::Gps``, :mod:`~gps_error_ros.ns3.native`). The radio keeps
the true position.

The errors are those of ``gps_error simulate`` and the error node for the
same profile, seed and agent names: the source turns one epoch into fixes
with the step that ``simulate`` uses on an FCD file
(:class:`~gps_error_ros.sim.fcd_step.FcdSteps`), on the positions placed on
the globe about a datum (``datum``: ns-3's x/y are east/north metres from
it). A profile's outages and faults leave a node without a fix.
"""

from collections.abc import Sequence
from dataclasses import dataclass, field
import math
from typing import Any

import numpy as np

from gps_error_ros.model.about_truth import model_about_truth, reported_mean
from gps_error_ros.model.geodesy import LocalTangentFrame
from gps_error_ros.model.profiles import Profile
from gps_error_ros.model.state import AgentState, BoolArray, FloatArray
from gps_error_ros.ns3.native import cpp, FIELDS
from gps_error_ros.sim.faults import Fault
from gps_error_ros.sim.fcd_step import FcdOptions, FcdSteps
from gps_error_ros.sim.trajectory_fixes import model_step

#: The stated accuracy's columns (m, m, m, degrees from north), in the table's order.
ACCURACY = ('accuracy', 'accuracy_major', 'accuracy_minor', 'accuracy_orientation')
#: Where ns-3's origin is unless told: Manhattan, where the paper's phones walked.
MANHATTAN = (40.75057, -73.99065)


@dataclass
class Epochs:
    """What a source gave at each epoch (``keep=True``): one row per epoch and node."""

    t: list[float] = field(default_factory=list)
    truth: list[FloatArray] = field(default_factory=list)
    position: list[FloatArray] = field(default_factory=list)
    error: list[FloatArray] = field(default_factory=list)
    fix: list[BoolArray] = field(default_factory=list)
    accuracy: list[FloatArray] = field(default_factory=list)

    def arrays(self) -> dict[str, FloatArray]:
        """
        Return the epochs as arrays.

        ``t`` (k,); ``truth`` and ``position`` (k, n, 2) x/y; ``error`` (k,
        n, 2) north/east; ``fix`` (k, n); ``accuracy`` (k, n, 4), the
        stated accuracy's columns (``ACCURACY``).
        """
        return {'t': np.asarray(self.t), 'truth': np.asarray(self.truth),
                'position': np.asarray(self.position), 'error': np.asarray(self.error),
                'fix': np.asarray(self.fix), 'accuracy': np.asarray(self.accuracy)}


class GpsSource:
    """
    The GPS fix of every node of ``nodes``, updated once per epoch of the profile's rate.

    Parameters
    ----------
    nodes
        An ns-3 ``NodeContainer`` whose nodes have a ``MobilityModel``.
    profile
        The phones' profile (:func:`gps_error_ros.load_profile`); None: no
        errors (every node knows its true position, with an accuracy of 0).
    seed
        The run's seed, as ``simulate``'s and the node's.
    names
        Each node's agent name (its errors' stream); default ``node<id>``.
    datum
        (lat, lon) of ns-3's origin: x/y are metres east and north of it.
    covariance_mode
        What accuracy the fix states, as ``simulate``'s option.
    covariance_about
        What that accuracy covers, 'truth' or 'mean', as ``simulate``'s option.
    faults
        Faults laid over the fixes (times on the simulation's clock).
    keep
        Keep every epoch's truth, position and error (:attr:`epochs`).
    start
        The time (s) the agents' errors start from, as ``simulate``'s run
        starts at its file's first timestep with an agent; None: the first
        epoch the source makes.

    """

    def __init__(self, nodes: Any, profile: Profile | None, seed: int,
                 names: Sequence[str] | None = None,
                 datum: tuple[float, float] = MANHATTAN, covariance_mode: str = 'stationary',
                 covariance_about: str = 'truth', faults: Sequence[Fault] = (),
                 keep: bool = False, start: float | None = None) -> None:
        self.nodes = nodes
        self.n = int(nodes.GetN())
        self.ids = np.array([nodes.Get(i).GetId() for i in range(self.n)], dtype=np.int64)
        self.names = list(names) if names is not None else [f'node{i}' for i in self.ids]
        if len(self.names) != self.n or len(set(self.names)) != self.n:
            raise ValueError(f'names: expected {self.n} distinct agent names, one per node, '
                             f'got {len(self.names)} ({len(set(self.names))} distinct)')
        self.frame = LocalTangentFrame(*datum)
        self.rate_hz = profile.rate_hz if profile is not None else 1.0
        self.steps: FcdSteps[AgentState] | None = None
        if profile is not None:
            # as simulate: covariances about the truth, or for a reported radius
            # the radius's circle plus the mean's m m^T
            model = profile.model(about_truth=model_about_truth(covariance_about,
                                                                covariance_mode))
            options = FcdOptions('lonlat', None, profile.rate_hz, seed, covariance_mode, None,
                                 profile.reported_accuracy, profile.velocity,
                                 reported_mean(model, covariance_about), tuple(faults))
            self.steps = FcdSteps('ns-3', model, options, None if start is None
                                  else model_step(start, profile.rate_hz))
        self.table = np.zeros((int(self.ids.max()) + 1 if self.n else 0, len(FIELDS)))
        self.epochs: Epochs | None = Epochs() if keep else None
        self._states = np.zeros((self.n, 4))
        self._cpp = cpp()

    def run(self, until: float) -> None:
        """Run ns-3 to ``until`` (s), updating every fix at each epoch on the way."""
        from ns import ns
        period = 1.0 / self.rate_hz
        k = math.ceil(ns.Simulator.Now().GetSeconds() * self.rate_hz - 1e-9)
        while k * period <= until + 1e-12:
            self._run_to(k * period)
            self.update(k * period)
            k += 1
        self._run_to(until)

    def update(self, t: float | None = None) -> None:
        """Make every node's fix at time ``t`` (s; default now) from its truth and its errors."""
        from ns import ns
        t = ns.Simulator.Now().GetSeconds() if t is None else t
        self._cpp.TrueStates(self.nodes, self._states)
        x, y, vx, vy = self._states.T
        lat, lon, _ = self.frame.to_geodetic(x, y)
        speed: FloatArray = np.hypot(vx, vy)
        heading: FloatArray = np.degrees(np.arctan2(vx, vy)) % 360.0
        if self.steps is None:
            fix = np.ones(self.n, dtype=bool)
            nlat, nlon, nx, ny = np.asarray(lat), np.asarray(lon), x, y
            acc: FloatArray = np.zeros((self.n, 4))
            err: FloatArray = np.zeros((self.n, 2))
        else:
            out = self.steps.timestep(t, self.names, lon, lat)
            fix, err = out.fix, out.error
            nlon, nlat = out.x, out.y
            nx, ny, _ = self.frame.to_enu(nlat, nlon)
            acc = np.stack([np.asarray(out.accuracy[k], dtype=float) for k in ACCURACY], 1)
            if out.velocity:
                speed = out.velocity['reported_speed']
                heading = out.velocity['reported_bearing']
        rows = np.column_stack([fix, np.full(self.n, t), nlat, nlon, nx, ny, acc, speed,
                                heading])
        rows[~fix, 2:] = np.nan
        self.table[self.ids] = rows
        self._cpp.Gps.Set(self.table.shape[0], self.table)
        if self.epochs is not None:
            e = self.epochs
            e.t.append(t)
            e.truth.append(np.column_stack([x, y]))
            e.position.append(np.column_stack([nx, ny]))
            e.error.append(np.asarray(err, dtype=float).copy())
            e.fix.append(np.asarray(fix, dtype=bool).copy())
            e.accuracy.append(acc.copy())

    def fix(self, index: int) -> dict[str, float]:
        """Return node ``index``'s (in ``nodes``) current fix, by field (see ``native.FIELDS``)."""
        return dict(zip(FIELDS, self.table[self.ids[index]].tolist()))

    @staticmethod
    def _run_to(t: float) -> None:
        """Run ns-3's events up to time ``t`` (s) (nothing when already there)."""
        from ns import ns
        ahead = int(round(t * 1e9)) - int(ns.Simulator.Now().GetNanoSeconds())
        if ahead > 0:
            ns.Simulator.Stop(ns.NanoSeconds(ahead))
            ns.Simulator.Run()
