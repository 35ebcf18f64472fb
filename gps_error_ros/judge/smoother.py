"""
A factor-graph consumer of the fixes: GTSAM's iSAM2 with GPS and odometry factors.

A study that localises with a factor graph rather than a filter sees the
fixes through a smoother: each pose ``x_i`` (a ``Pose3`` on the local
north-east plane) gets a ``GPSFactor`` from its fix, with the training
part's mean square error per axis as its variance and a Huber loss
(:data:`HUBER_K`, as a graph that must survive bad fixes is usually built),
and a ``BetweenFactorPose3`` to the pose before it from the velocity aid
(the truth's velocity plus noise of
:data:`~gps_error_ros.judge.consumers.VELOCITY_SD` m/s, the same draws
as the filter's). iSAM2 adds one pose per sample. Measures:

* ``smoother_online_rms_m`` and ``smoother_online_p95_m``: the horizontal
  error of the newest pose's estimate right after its sample (what a robot
  acts on);
* ``smoother_rms_m``: the horizontal RMS error of the whole trajectory as
  smoothed after the last sample.

GTSAM is the optional extra ``smoother`` (``pip install gtsam``); without it
:func:`available` is false and :func:`run_smoother` raises ``ImportError``
with what to install.
"""

from typing import Any

import numpy as np

from gps_error_ros.fit.holdout import Part
from gps_error_ros.judge.consumers import _grid, _truth_velocity, VELOCITY_SD
from gps_error_ros.model.state import FloatArray, Numbers

#: The Huber loss's threshold, in standard deviations of a fix.
HUBER_K = 1.345
#: The measures, in order.
SMOOTHER_MEASURES = ('smoother_online_rms_m', 'smoother_online_p95_m', 'smoother_rms_m')
#: What to install for the smoother.
INSTALL = 'pip install gtsam (the optional extra "smoother": requirements-smoother.txt)'


def available() -> bool:
    """Return whether GTSAM can be imported."""
    try:
        import gtsam  # noqa: F401
    except ImportError:
        return False
    return True


def _gtsam() -> Any:
    try:
        import gtsam
    except ImportError as exc:
        raise ImportError(f'the smoother consumer needs GTSAM: {INSTALL}') from exc
    return gtsam


def head(part: Part, n: int) -> Part:
    """
    Return the first ``n`` samples of a ``Part``, its segments kept.

    Within the part's first recording: the smoother never bridges two recordings.
    """
    out, left = Part([], [], []), n
    labels, kept = part.recordings(), []
    for e, r, t, rec in zip(part.err, part.truth, part.t, labels):
        if left <= 0 or rec != labels[0]:
            break
        out.err.append(e[:left])
        out.truth.append(r[:left])
        out.t.append(t[:left])
        kept.append(rec)
        left -= len(e)
    out.recording = kept
    return out


def run_smoother(part: Part, errors: FloatArray, fix_var: Numbers,
                 seed: int = 0) -> FloatArray:
    """
    Return the smoother measures for each error trace, (traces, 3).

    ``errors``: (traces, n, 2) north/east errors at the part's samples;
    ``fix_var``: (2,) the stated fix variance per axis. In the order of
    :data:`SMOOTHER_MEASURES`. A gap between segments is bridged by the
    velocity aid over its duration, as the filter bridges it.
    """
    gtsam = _gtsam()
    t, truth, first, _ = _grid(part)
    vel = _truth_velocity(t, truth, first)
    aid = vel + VELOCITY_SD * np.random.default_rng(seed).standard_normal(vel.shape)
    sd = np.sqrt(np.maximum(np.asarray(fix_var, dtype=float), 1e-6))
    gps = gtsam.noiseModel.Robust.Create(
        gtsam.noiseModel.mEstimator.Huber.Create(HUBER_K),
        gtsam.noiseModel.Diagonal.Sigmas(np.array([sd[0], sd[1], 0.1])))
    tight = 1e-3       # rotation and height: the walk stays on the plane
    start = gtsam.noiseModel.Diagonal.Sigmas(np.array([tight] * 3 + [1e3, 1e3, 0.1]))
    between: dict[float, Any] = {}

    def odometry(dt: float) -> Any:
        if dt not in between:
            between[dt] = gtsam.noiseModel.Diagonal.Sigmas(np.array(
                [tight] * 3 + [VELOCITY_SD * dt, VELOCITY_SD * dt, 0.01]))
        return between[dt]

    out = np.empty((errors.shape[0], len(SMOOTHER_MEASURES)))
    for k, err in enumerate(errors):
        fixes = truth + err
        isam = gtsam.ISAM2()
        online = np.empty((t.size, 2))
        for i in range(t.size):
            graph, guess = gtsam.NonlinearFactorGraph(), gtsam.Values()
            graph.add(gtsam.GPSFactor(i, gtsam.Point3(fixes[i, 0], fixes[i, 1], 0.0), gps))
            if i == 0:
                graph.add(gtsam.PriorFactorPose3(0, gtsam.Pose3(), start))
                at = fixes[0]
            else:
                dt = round(max(float(t[i] - t[i - 1]), 1e-3), 3)
                move = aid[i] * dt
                graph.add(gtsam.BetweenFactorPose3(
                    i - 1, i, gtsam.Pose3(gtsam.Rot3(), gtsam.Point3(move[0], move[1], 0.0)),
                    odometry(dt)))
                at = online[i - 1] + move
            guess.insert(i, gtsam.Pose3(gtsam.Rot3(), gtsam.Point3(at[0], at[1], 0.0)))
            isam.update(graph, guess)
            online[i] = isam.calculateEstimatePose3(i).translation()[:2]
        final = isam.calculateEstimate()
        smoothed = np.array([final.atPose3(i).translation()[:2] for i in range(t.size)])
        h_online = np.hypot(*(online - truth).T)
        h_smooth = np.hypot(*(smoothed - truth).T)
        out[k] = (np.sqrt(np.mean(h_online ** 2)), np.quantile(h_online, 0.95),
                  np.sqrt(np.mean(h_smooth ** 2)))
    return out
