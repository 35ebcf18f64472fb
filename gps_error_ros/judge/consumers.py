"""
What a consumer of the fixes concludes: a localisation filter and a V2P warning.

A simulator is good for a study when the study's conclusions from simulated
fixes are those from real ones. Both consumers run on the same truth and
time grid with the measured errors and with each simulated trace, and with
the same settings, tuned on the training part as a study would tune them:

* **Filter**: a constant-velocity Kalman filter (state north, east and
  their velocities; white acceleration of :data:`ACCEL_SD` m/s^2) fusing a
  velocity aid (the truth's velocity plus noise of :data:`VELOCITY_SD` m/s,
  as odometry or step counting gives, the same draws for every trace) and
  the fixes, whose stated covariance is the training part's mean square
  error per axis. A fix whose normalised innovation exceeds the chi-squared
  0.99 point (2 degrees of freedom) is rejected, as robot_localization's
  Mahalanobis gate does. Measures: the filtered position's horizontal RMS
  and 95 % error, its mean NEES (2 for a consistent filter) and the share
  of fixes the gate rejects.
* **V2P warning**: at every sample a vehicle's path (a straight line at a
  distance ``d`` from the pedestrian, uniform within ``+-(W + 3 s)``, in a
  direction uniform on the circle; the same draws for every trace) is in
  conflict when ``|d| < W`` (:data:`CONFLICT_M`); the vehicle warns when
  the broadcast position lies within ``W + s`` of its path, ``s`` the
  stated accuracy (the root mean square of the training part's error per
  axis). Measures: the share of conflicts warned and the share of
  non-conflicts warned (false warnings).
"""

from collections.abc import Sequence

import numpy as np
from scipy import stats

from gps_error_ros.fit.holdout import Part
from gps_error_ros.fit.envelope import envelope, Envelope
from gps_error_ros.model.state import BoolArray, FloatArray

#: The filter's white acceleration, m/s^2.
ACCEL_SD = 0.5
#: The velocity aid's noise per axis, m/s.
VELOCITY_SD = 0.2
#: The gate: chi-squared 0.99 point with 2 degrees of freedom.
GATE = float(stats.chi2.ppf(0.99, 2))
#: Half-width of a vehicle's path in which a pedestrian is in conflict, m.
CONFLICT_M = 2.0
#: The measures, in order.
FILTER_MEASURES = ('filter_rms_m', 'filter_p95_m', 'filter_nees', 'filter_gate_rate')
V2P_MEASURES = ('v2p_warned', 'v2p_false_warning')
#: What the filter's error is made of (:func:`filter_parts`), in order.
FILTER_PARTS = ('mean_size_m', 'sd_m', 'filter_rms_per_sd')


def _grid(part: Part) -> tuple[FloatArray, FloatArray, BoolArray, BoolArray]:
    """Return (times, truth (n, 2), segment start flags, recording start flags) of a part."""
    t = np.concatenate(part.t)
    truth = np.concatenate(part.truth)
    first = np.zeros(t.size, dtype=bool)
    starts = np.cumsum([0] + [len(x) for x in part.t[:-1]])
    first[starts] = True
    new_run = np.zeros(t.size, dtype=bool)
    new_run[starts[np.asarray(part.recording_starts(), dtype=bool)]] = True
    return t, truth, first, new_run


def _truth_velocity(t: FloatArray, truth: FloatArray, first: BoolArray) -> FloatArray:
    """Return the truth's velocity at each sample (backward difference; forward at a start)."""
    v = np.zeros_like(truth)
    if t.size > 1:
        d = np.diff(truth, axis=0) / np.maximum(np.diff(t), 1e-3)[:, None]
        v[1:] = d
        starts = np.flatnonzero(first)
        starts = starts[starts < t.size - 1]
        v[starts] = d[starts]
    return v


def run_filter(part: Part, errors: FloatArray, fix_var: FloatArray,
               seed: int = 0) -> FloatArray:
    """
    Return the filter measures for each error trace.

    ``errors``: (traces, n, 2) north/east errors at the part's samples (the
    measured one among them); ``fix_var``: (2,) the stated fix variance per
    axis. Returns an array (traces, 4) in the order of :data:`FILTER_MEASURES`.

    The filter starts at the first fix of each recording in the part (as a
    consumer switched on anew), and coasts across gaps within one.
    """
    t, truth, first, new_run = _grid(part)
    vel = _truth_velocity(t, truth, first)
    aid = vel + VELOCITY_SD * np.random.default_rng(seed).standard_normal(vel.shape)
    k = errors.shape[0]
    fixes = truth[None] + errors
    p0 = np.diag([fix_var[0], fix_var[1], VELOCITY_SD ** 2, VELOCITY_SD ** 2])
    r_fix = np.diag(fix_var)
    r_vel = np.eye(2) * VELOCITY_SD ** 2
    est = np.empty((t.size, k, 2))
    nees = np.empty((t.size, k))
    rejected = np.zeros(k)
    for i in range(t.size):
        if new_run[i]:
            x = np.concatenate([fixes[:, i], np.repeat(aid[i][None], k, axis=0)], axis=1)
            p = np.repeat(p0[None], k, axis=0)
            est[i], nees[i] = x[:, :2], _nees(x[:, :2] - truth[i], p[:, :2, :2])
            continue
        dt = max(float(t[i] - t[i - 1]), 1e-3)
        f = np.eye(4)
        f[0, 2] = f[1, 3] = dt
        q = ACCEL_SD ** 2 * np.array([[dt ** 3 / 3, 0, dt ** 2 / 2, 0],
                                      [0, dt ** 3 / 3, 0, dt ** 2 / 2],
                                      [dt ** 2 / 2, 0, dt, 0],
                                      [0, dt ** 2 / 2, 0, dt]])
        x = x @ f.T
        p = f @ p @ f.T + q
        x, p, _ = _update(x, p, aid[i][None] - x[:, 2:], slice(2, 4), r_vel)
        nu = fixes[:, i] - x[:, :2]
        x, p, ok = _update(x, p, nu, slice(0, 2), r_fix, gate=GATE)
        rejected += ~ok
        est[i] = x[:, :2]
        nees[i] = _nees(x[:, :2] - truth[i], p[:, :2, :2])
    h = np.hypot(*(est - truth[:, None]).transpose(2, 0, 1))
    updates = max(t.size - int(new_run.sum()), 1)
    return np.stack([np.sqrt(np.mean(h ** 2, axis=0)), np.quantile(h, 0.95, axis=0),
                     nees.mean(axis=0), rejected / updates], axis=1)


def _nees(err: FloatArray, cov: FloatArray) -> FloatArray:
    return np.einsum('ki,kij,kj->k', err, np.linalg.inv(cov), err)


def _update(x: FloatArray, p: FloatArray, nu: FloatArray, sel: slice, r: FloatArray,
            gate: float | None = None) -> tuple[FloatArray, FloatArray, BoolArray]:
    """Update with a measurement of the state's ``sel`` entries; innovation ``nu`` (k, 2)."""
    s = p[:, sel, sel] + r
    s_inv = np.linalg.inv(s)
    ok = np.ones(x.shape[0], dtype=bool)
    if gate is not None:
        ok = np.einsum('ki,kij,kj->k', nu, s_inv, nu) <= gate
    gain = p[:, :, sel] @ s_inv                                  # (k, 4, 2)
    gain[~ok] = 0.0
    x = x + np.einsum('kij,kj->ki', gain, nu)
    p = p - gain @ p[:, sel, :]
    return x, p, ok


def v2p_warnings(part: Part, errors: FloatArray, accuracy_m: float,
                 seed: int = 0) -> FloatArray:
    """
    Return the V2P measures for each error trace, (traces, 2).

    ``accuracy_m``: the stated accuracy ``s`` (one-axis SD) every trace
    broadcasts. In the order of :data:`V2P_MEASURES`.
    """
    n = errors.shape[1]
    rng = np.random.default_rng(seed)
    reach = CONFLICT_M + 3.0 * accuracy_m
    d = rng.uniform(-reach, reach, n)
    theta = rng.uniform(0.0, 2.0 * np.pi, n)
    normal = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    conflict = np.abs(d) < CONFLICT_M
    along = np.einsum('kni,ni->kn', errors, normal)
    warned = np.abs(along - d) < CONFLICT_M + accuracy_m
    hit = (warned & conflict).sum(axis=1) / max(conflict.sum(), 1)
    false = (warned & ~conflict).sum(axis=1) / max((~conflict).sum(), 1)
    return np.stack([hit, false], axis=1)


def _stacked(measured: Sequence[FloatArray], simulated: Sequence[Sequence[FloatArray]],
             train_err: Sequence[FloatArray]) -> tuple[FloatArray, FloatArray]:
    """Return (the fixes' stated variance per axis (2,), the errors (traces, n, 2))."""
    fix_var = np.mean(np.concatenate(train_err) ** 2, axis=0)
    errors = np.stack([np.concatenate(measured)] + [np.concatenate(s) for s in simulated])
    return fix_var, errors


def filter_parts(part: Part, measured: Sequence[FloatArray],
                 simulated: Sequence[Sequence[FloatArray]], train_err: Sequence[FloatArray],
                 seed: int = 0) -> dict[str, Envelope]:
    """
    Return {name: envelope row} of what the filter's RMS error is made of (:data:`FILTER_PARTS`).

    Over the part, a filter that averages many fixes errs by about the
    error's mean, plus what it lets through of the error about that mean.
    So, per trace (measured and each simulated, as :func:`consumer_measures`
    takes them): the size of the error's mean (m, both axes), its SD (m,
    root of the summed variances), and the filter's RMS on the error less
    its mean divided by that SD (the filter's response to the error's
    dynamics, whatever its scale). A filter measure outside its range with
    these three inside has another cause; with them outside, it is theirs.
    """
    fix_var, errors = _stacked(measured, simulated, train_err)
    mean = errors.mean(axis=1)
    sd = np.sqrt(errors.var(axis=1).sum(axis=1))
    rms = run_filter(part, errors - mean[:, None, :], fix_var, seed)[:, 0]
    values = np.column_stack([np.hypot(mean[:, 0], mean[:, 1]), sd,
                              rms / np.maximum(sd, 1e-12)])
    return {name: envelope(values[0, j], values[1:, j]) for j, name in enumerate(FILTER_PARTS)}


def consumer_measures(part: Part, measured: Sequence[FloatArray],
                      simulated: Sequence[Sequence[FloatArray]],
                      train_err: Sequence[FloatArray],
                      seed: int = 0) -> tuple[list[str], FloatArray, FloatArray]:
    """
    Return (names, measured (m,), simulated (sims, m)) of both consumers.

    ``measured``: the part's error segments; ``simulated``: a list of
    traces, each a list of segments; ``train_err``: the training part's
    error segments (the settings are tuned on them).
    """
    fix_var, errors = _stacked(measured, simulated, train_err)
    filt = run_filter(part, errors, fix_var, seed)
    v2p = v2p_warnings(part, errors, float(np.sqrt(fix_var.mean())), seed)
    values = np.concatenate([filt, v2p], axis=1)
    return list(FILTER_MEASURES + V2P_MEASURES), values[0], values[1:]
