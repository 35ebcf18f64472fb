"""
The package in a few names: smartphone GPS errors in Python, without ROS.

Everything here is also what the node and ``gps_error simulate`` do: the
same seed, agent names and profile give the same errors (every draw is a
pure function of seed, agent and step). The examples run in ``make test``
from the repository's root (they read its ``data/``).

Examples
--------
>>> import gps_error_ros as ge
>>> profile = ge.load_profile('DS5')
>>> errors = ge.simulate_errors(profile, agents=3, duration_s=60, seed=42)
>>> errors.north_east.shape
(3, 60, 2)

"""

from collections.abc import Sequence
from dataclasses import dataclass
import os
from typing import Any, Literal
import warnings

import numpy as np
import numpy.typing as npt

from gps_error_ros.fit.calibration import calibrate as _calibrate
from gps_error_ros.fit.gross_failures import find_gross_failures
from gps_error_ros.fit.validation import FAILURE_COLUMN, ValidationResult
from gps_error_ros.fit.validation import validate as _validate
from gps_error_ros.model import profiles
from gps_error_ros.model.geodesy import difference, LocalTangentFrame
from gps_error_ros.model.profiles import Profile
from gps_error_ros.model.reported import needs_predictive
from gps_error_ros.model.state import BoolArray, FloatArray
from gps_error_ros.model.stepping import run
from gps_error_ros.model.streams import agent_keys
from gps_error_ros.sim.faults import Fault, faults_from_yaml
from gps_error_ros.sim.trajectory_fixes import agent_names, model_step, Stated, trajectory_fixes
from gps_error_ros.sim.velocity_sim import row_values
from gps_error_ros.traces.loading import load_trace
from gps_error_ros.traces.progress import stage_progress

__all__ = ['Errors', 'Fixes', 'Profile', 'add_errors', 'calibrate', 'load_profile',
           'simulate_errors', 'to_enu', 'validate']

PathLike = str | os.PathLike[str]
#: Times, coordinates or metres, one per row: a numpy array, or a sequence of numbers.
Series = Sequence[float] | npt.NDArray[Any]
#: What the node states as each fix's covariance (its ``covariance_mode``).
CovarianceMode = Literal['stationary', 'conditional', 'reported']
MODES = ('stationary', 'conditional', 'reported')


def load_profile(spec: PathLike) -> Profile:
    """
    Return a profile: a built-in name (case-insensitive) or a profile YAML's path.

    Built-in: the paper's ``DS1``, ``DS2``, ``DS5``, ``DS7`` and the presets
    (``phone-suburban-drive``, ``snapshot-receiver-on-foot``; see the
    documentation's presets page).

    Examples
    --------
    >>> profile = load_profile('phone-suburban-drive')
    >>> profile.velocity is not None, profile.availability is None
    (True, True)

    """
    return profiles.load_profile(spec)


@dataclass(frozen=True)
class Errors:
    """
    Errors of agents over time, from :func:`simulate_errors`.

    ``north_east`` is the error about the truth (m, north then east) of every
    agent and step, ``(agents, steps, 2)``; it runs on through outages.
    ``fix`` is False where the agent has no fix (an outage: the node
    publishes NO_FIX there); it is True throughout for a profile without an
    ``availability`` section (no built-in one has one: put outages where you
    want them with :func:`add_errors`' faults); ``failed`` marks a gross failure
    (a fix far off; never where there is no fix); ``covariance``
    ``(agents, steps, 2, 2)`` is what the node states in its
    ``covariance_mode``; ``velocity`` ``(agents, steps, 2)`` is the
    reported velocity's error (east, north m/s) where the profile has a
    ``velocity`` section, else None.

    Examples
    --------
    >>> drive = load_profile('phone-suburban-drive')
    >>> e = simulate_errors(drive, agents=2, duration_s=300, seed=3)
    >>> e.names, e.t[:3]
    (['agent0', 'agent1'], array([0., 1., 2.]))
    >>> e.north_east.shape, e.fix.shape, e.velocity.shape
    ((2, 300, 2), (2, 300), (2, 300, 2))
    >>> e.covariance.shape
    (2, 300, 2, 2)
    >>> import numpy as np
    >>> north, east = e.north_east[0, :, 0], e.north_east[0, :, 1]
    >>> rms = float(np.sqrt(np.mean(north**2 + east**2)))
    >>> 0.2 < rms < 5          # a phone in a car: about a metre or two
    True

    """

    t: FloatArray
    names: list[str]
    north_east: FloatArray
    fix: BoolArray
    failed: BoolArray
    covariance: FloatArray
    velocity: FloatArray | None


def simulate_errors(profile: Profile, agents: int | Sequence[str], duration_s: float,
                    seed: int, start_s: float = 0.0,
                    covariance_mode: CovarianceMode = 'stationary') -> Errors:
    """
    Return the errors of ``agents`` (a number, or names) over ``duration_s`` seconds.

    Agents given by number are named ``agent0``, ``agent1``, ... as in
    ``gps_error simulate --agents``. ``covariance_mode``: ``stationary`` (the
    profile's covariance about the truth), ``conditional`` (each step's, given
    the step before) or ``reported`` (what the phone states; needs a
    ``reported_accuracy`` section).

    Examples
    --------
    >>> profile = load_profile('snapshot-receiver-on-foot')
    >>> e = simulate_errors(profile, ['ann', 'bob'], duration_s=600, seed=1,
    ...                     covariance_mode='conditional')
    >>> e.north_east.shape, e.covariance.shape
    ((2, 600, 2), (2, 600, 2, 2))
    >>> int(e.failed.sum()) > 0          # this receiver fails now and then
    True
    >>> bool(e.fix.all())                # no outages in this profile
    True

    """
    if covariance_mode not in MODES:
        raise ValueError(f'covariance_mode {covariance_mode!r}: expected one of {MODES}')
    names = agent_names(agents) if isinstance(agents, int) else list(agents)
    steps = int(round(duration_s * profile.rate_hz))
    start = model_step(start_s, profile.rate_hz)
    keys = agent_keys(seed, names)
    about = covariance_mode != 'reported'
    model = profile.model(about_truth=about)
    conditional = needs_predictive(covariance_mode, profile.reported_accuracy)
    result = run(model, keys, start, steps, cov=conditional)
    cov = result.covariance
    if cov is None:
        cov = np.repeat(np.asarray(model.stationary_cov)[None, None], len(names), axis=0)
        cov = np.repeat(cov, steps, axis=1)
    t = (start + np.arange(steps)) / profile.rate_hz
    if covariance_mode == 'reported':
        cov = _stated_cov(profile, model, seed, names, t, start, cov)
    velocity = None if profile.velocity is None else \
        profile.velocity.errors(keys, steps, start).transpose(1, 0, 2)
    return Errors(t, names, result.errors, result.fix, result.failed, cov, velocity)


def _stated_cov(profile: Profile, model: Any, seed: int, names: Sequence[str],
                t: FloatArray, start: int, cov: FloatArray) -> FloatArray:
    """Return the covariance the phone states at every (agent, step): mode ``reported``."""
    stated = Stated(model, profile.reported_accuracy, seed, model.mean)
    n, steps = cov.shape[:2]
    rows_agent = np.repeat(np.asarray(names, dtype=object), steps)
    rows_t = np.tile(t, n)
    x = row_values(stated.reported, seed, rows_agent, rows_t, start, profile.rate_hz)
    _, out = stated.radius(x, cov.reshape(n * steps, 2, 2))
    return out.reshape(n, steps, 2, 2)


@dataclass(frozen=True)
class Fixes:
    """
    A trajectory's fixes, from :func:`add_errors`: one row per input row.

    ``lat``, ``lon`` are NaN where ``fix`` is False (an outage);
    ``covariance`` ``(rows, 2, 2)`` north/east m^2 is what the node states;
    ``accuracy`` the 68 % radius stated (m). ``failed`` marks a gross failure
    of the profile's section (a fault's are at the times you chose).
    ``error`` ``(rows, 2)`` is each fix's error about the truth (m, north
    then east, as :class:`Errors`; NaN without a fix). With a datum,
    ``east`` and ``north`` are the fixes in its ENU frame (m), else None.
    ``speed`` (m/s) and ``bearing`` (degrees from north) are what the phone
    reports where the profile has a ``velocity`` section, else None.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(0.0, 120.0)
    >>> fixes = add_errors(load_profile('phone-suburban-drive'), t, seed=7,
    ...                    lat=np.full(120, 37.4220), lon=-122.0841 + 1e-4 * t)
    >>> fixes.lat.shape, fixes.error.shape, fixes.agent[0] == ''
    ((120,), (120, 2), True)
    >>> float(np.median(np.hypot(*fixes.error.T))) < 5    # metres off the truth
    True
    >>> fixes.speed is not None, fixes.east is None   # a velocity; no datum
    (True, True)

    """

    t: FloatArray
    agent: list[str]
    lat: FloatArray
    lon: FloatArray
    fix: BoolArray
    covariance: FloatArray
    accuracy: FloatArray
    failed: BoolArray
    error: FloatArray
    east: FloatArray | None = None
    north: FloatArray | None = None
    speed: FloatArray | None = None
    bearing: FloatArray | None = None


def add_errors(profile: Profile, t: Series, seed: int, lat: Series | None = None,
               lon: Series | None = None, *, east: Series | None = None,
               north: Series | None = None, datum: Sequence[float] | None = None,
               agents: Sequence[str] | None = None,
               covariance_mode: CovarianceMode = 'stationary',
               faults: Sequence[Fault] | str = (), zones: PathLike | None = None) -> Fixes:
    """
    Return the fixes a phone would give along true positions.

    Give ``lat`` and ``lon`` (degrees), or ``east`` and ``north`` (m) in the
    ENU frame of ``datum`` (``[lat, lon]`` or ``[lat, lon, alt]``). Rows are
    in time order (``t``, s), the rows of all agents sorted together;
    ``agents`` names each row's agent (default: one agent, ``''``, as the
    single-agent node). ``faults``: faults on demand as YAML text, one
    fault, a list of them or ``{faults: [...]}``, as the node's ``faults``
    parameter takes them (the documentation's faults page). ``zones``: a
    zone map (GeoJSON) whose zones' profiles apply where the truth is, as
    the node's ``zones`` parameter. A row without a fix (an outage) has NaN
    position, covariance and accuracy.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(1000.0, 1060.0)
    >>> fixes = add_errors(load_profile('DS5'), t, seed=7, east=1.3 * (t - 1000),
    ...                    north=np.zeros(60), datum=[40.75057, -73.99065])
    >>> fixes.east.shape, bool(fixes.fix.all())
    ((60,), True)
    >>> fixes.covariance.shape            # north/east m^2, what the node states
    (60, 2, 2)
    >>> bool(np.allclose(fixes.accuracy, fixes.accuracy[0]))  # one radius
    True
    >>> outage = '{kind: outage, at: 1010, duration: 5}'
    >>> fixes = add_errors(load_profile('DS5'), t, seed=7, east=1.3 * (t - 1000),
    ...                    north=np.zeros(60), datum=[40.75057, -73.99065],
    ...                    faults=outage)
    >>> int((~fixes.fix).sum())
    5

    In latitude and longitude, two agents, their rows sorted together by time:

    >>> t2 = np.repeat(np.arange(0.0, 30.0), 2)
    >>> fixes = add_errors(load_profile('DS5'), t2, seed=7, lat=40.75 + 1e-5 * t2,
    ...                    lon=np.full(60, -73.99), agents=['ann', 'bob'] * 30)
    >>> fixes.lat.shape, fixes.east is None
    ((60,), True)

    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if covariance_mode not in MODES:
        raise ValueError(f'covariance_mode {covariance_mode!r}: expected one of {MODES}')
    _same_lengths(t=t, lat=lat, lon=lon, east=east, north=north, agents=agents)
    if isinstance(faults, str):
        faults = faults_from_yaml(faults, 'faults')
    if (lat is not None or lon is not None) and (east is not None or north is not None):
        raise ValueError('give lat and lon (degrees), or east, north and datum: not both')
    if datum is None and (east is not None or north is not None):
        raise ValueError('east and north need datum, the [lat, lon] their ENU frame is about')
    frame = None
    if datum is not None:
        if len(datum) not in (2, 3):
            raise ValueError(f'datum {list(datum)!r}: expected [lat, lon] or [lat, lon, alt]')
        frame = LocalTangentFrame(*datum)
        if east is None or north is None:
            raise ValueError('with datum, give east and north (m in its ENU frame)')
        lat, lon, _ = frame.to_geodetic(np.asarray(east, float), np.asarray(north, float),
                                        np.zeros(t.size))
    if lat is None or lon is None:
        raise ValueError('give lat and lon (degrees), or east, north and datum')
    _positions(np.asarray(lat, float), np.asarray(lon, float))
    names = [''] * t.size if agents is None else list(agents)
    data = {'t': t, 'agent': names, 'truth_lat': np.asarray(lat, float),
            'truth_lon': np.asarray(lon, float)}
    about = covariance_mode != 'reported'
    model = profile.model(about_truth=about)
    zoned = None
    if zones is not None:
        from gps_error_ros.model.zoned import zoned_errors
        from gps_error_ros.model.zones import load_zone_map
        profile, model, zoned = zoned_errors(load_zone_map(zones), profile, covariance_mode,
                                             about)
    rows, radius = trajectory_fixes(data, model, profile.rate_hz, seed,
                                    velocity=profile.velocity,
                                    covariance_mode=covariance_mode, zones=zoned,
                                    reported=profile.reported_accuracy,
                                    reported_bias=model.mean, faults=faults)
    from gps_error_ros.model.accuracy import radius68
    accuracy = radius68(rows.cov) if radius is None else np.asarray(radius, float)
    accuracy = np.where(rows.fix, accuracy, np.nan)
    rows.cov[~rows.fix] = np.nan            # no fix: no stated covariance
    out_east = out_north = None
    if frame is not None:
        out_east, out_north, _ = frame.to_enu(rows.lat, rows.lon, np.zeros(t.size))
    speed = rows.extra.get('speed')
    bearing = rows.extra.get('bearing')
    north_err, east_err = difference(rows.lat, rows.lon, data['truth_lat'], data['truth_lon'])
    return Fixes(t, names, rows.lat, rows.lon, rows.fix, rows.cov, accuracy,
                 _failed_rows(profile, seed, names, t) & rows.fix,
                 np.stack([north_err, east_err], axis=1), out_east, out_north, speed, bearing)


def to_enu(lat: float | Series, lon: float | Series,
           datum: Sequence[float]) -> tuple[FloatArray, FloatArray]:
    """
    Return (east, north) metres of positions in the ENU frame of ``datum``.

    ``datum`` is ``[lat, lon]`` or ``[lat, lon, alt]`` (degrees, m above the
    ellipsoid), as the node's ``datum`` parameter and :func:`add_errors`'
    take it; positions are at the datum's height. To compare fixes with the
    truth (your simulator's, or the node's ``/fix`` against its ``/pose``),
    put both in one frame and subtract.

    Examples
    --------
    >>> east, north = to_enu([40.75057, 40.75147], [-73.99065, -73.99065],
    ...                      datum=[40.75057, -73.99065])
    >>> [round(float(v), 1) for v in north]        # 0.0009 degrees of latitude
    [0.0, 99.9]
    >>> bool(abs(east).max() < 1e-6)
    True

    """
    if len(datum) not in (2, 3):
        raise ValueError(f'datum {list(datum)!r}: expected [lat, lon] or [lat, lon, alt]')
    _same_lengths(lat=lat, lon=lon)
    frame = LocalTangentFrame(*datum)
    alt = float(datum[2]) if len(datum) == 3 else 0.0
    east, north, _ = frame.to_enu(np.asarray(lat, float), np.asarray(lon, float),
                                  np.full(np.shape(lat), alt))
    return np.asarray(east, float), np.asarray(north, float)


def _same_lengths(**columns: Any) -> None:
    """Raise ValueError naming the columns given (not None) when their lengths differ."""
    sizes = {k: int(np.size(v)) if not isinstance(v, (list, tuple)) else len(v)
             for k, v in columns.items() if v is not None}
    if len(set(sizes.values())) > 1:
        said = ', '.join(f'{k} {n}' for k, n in sizes.items())
        raise ValueError(f'one value per row expected, the same number of each: {said} '
                         f'values')


def _positions(lat: FloatArray, lon: FloatArray) -> None:
    """Raise ValueError naming the first row whose truth is not a position on Earth."""
    bad = ~(np.isfinite(lat) & np.isfinite(lon) & (np.abs(lat) <= 90.0) &
            (np.abs(lon) <= 180.0))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f'the truth of {int(bad.sum())} row(s) is not a position, the first '
                         f'row {i}: lat {float(lat[i])!r}, lon {float(lon[i])!r}; expected finite '
                         f'degrees, lat in [-90, 90] and lon in [-180, 180]')


def _failed_rows(profile: Profile, seed: int, names: Sequence[str], t: FloatArray) -> BoolArray:
    """Return which rows the profile's gross failures hit (the model's own draws)."""
    failed = np.zeros(t.size, dtype=bool)
    if profile.gross_failures is None or not t.size:
        return failed
    keys = agent_keys(seed, list(names))
    steps = np.array([model_step(v, profile.rate_hz) for v in t])
    for step in np.unique(steps):
        rows = np.flatnonzero(steps == step)
        failed[rows] = profile.gross_failures.offsets(keys[rows], int(step))[1]
    return failed


def calibrate(recordings: PathLike | Sequence[PathLike], population: bool = False,
              order: int | None = None, name: str = 'calibrated',
              within: Literal['extended', 'ar'] = 'extended',
              progress: bool | None = None) -> Profile:
    """
    Return a profile fitted to recordings of one receiver (trace CSVs or bags).

    As ``gps_error calibrate``. Without ``population``: one AR process per
    axis, the paper's model. With it: each agent its own bias and scale, as
    recordings and stretches differ, and within them the extended model
    (``within='extended'``, the class that predicted best on held-out days)
    or the Gaussian AR (``within='ar'``, faster; ``order`` fixes its order).
    ``profile.save(path)`` writes it for the node and the commands.

    The extended fit takes from seconds to minutes: its stages show as a
    bar on standard error (``progress``: None, on a terminal for long
    recordings; True always; False never). Asked for a population the
    recordings cannot give (fewer than three 300-s blocks), it returns the
    profile without one and warns why (``UserWarning``).

    Examples
    --------
    >>> profile = calibrate('data/gsdc2020-mtv1-pixel4.csv', order=3)
    >>> profile.axes['north'].order, profile.velocity is not None
    (3, True)
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     profile.save(os.path.join(folder, 'my_phone.yaml'))
    ...     load_profile(os.path.join(folder, 'my_phone.yaml')).axes['north'].order
    3
    >>> best = calibrate('data/gsdc2020-mtv1-pixel4.csv', population=True)
    >>> best.population is not None, 'heavy_tails' in best.effects.names
    (True, True)

    """
    if within not in ('extended', 'ar'):
        raise ValueError(f'within={within!r}: expected \'extended\' or \'ar\'')
    paths = [recordings] if isinstance(recordings, (str, os.PathLike)) else list(recordings)
    traces = [load_trace(p)[0] for p in paths]
    if population and within == 'extended':
        if order is not None:
            raise ValueError(f'order={order}: the extended model within a population chooses '
                             f'its own orders; pass within=\'ar\' to fix the order')
        from gps_error_ros.judge.population_calibration import calibrate_best, STAGES
        bar = stage_progress([len(t) for t in traces], [t.name for t in traces], STAGES,
                             'fitting the extended model within', show=progress)
        try:
            result = calibrate_best(traces, done=bar.update)
        finally:
            bar.close()
    else:
        result = _calibrate(traces, order=order, population=population)
    if population and result.population is not None and result.population.population is None:
        warnings.warn(f'calibrate: no population section, so the profile is the Gaussian AR '
                      f'of the recordings pooled (neither a population nor the extended '
                      f'model within it): {result.population.evidence["reason"]}',
                      UserWarning, stacklevel=2)
    return profiles.profile_from_dict(result.profile_dict(name))


def validate(profile: Profile, recording: PathLike, sims: int = 200,
             seed: int = 0) -> ValidationResult:
    """
    Return how a recording compares with traces the profile simulates.

    As ``gps_error validate``: autocorrelation and quantiles against the
    simulated 95 % envelopes, the stated accuracy and the outages; the
    recording's gross failures are left out on both sides.
    ``summary()`` is the text ``validate`` prints of the envelopes, stated accuracy
    and outages (the command adds the gross failures and the profile's class);
    ``to_dict()`` is its JSON.

    Examples
    --------
    >>> result = validate(load_profile('phone-suburban-drive'),
    ...                   'data/gsdc2020-mtv1-pixel4xlmodded.csv', sims=50)
    >>> result.samples
    1743
    >>> result.joint_pct > 5        # not unlike the model's own traces
    True

    """
    trace = load_trace(recording)[0]
    trace.extra[FAILURE_COLUMN] = find_gross_failures(trace).mask.astype(float)
    return _validate(profile.model(gross_failures=False), trace, sims=sims, seed=seed,
                     reported=profile.reported_accuracy)
