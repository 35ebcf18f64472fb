"""
The phone's stated accuracy, measured against simulated (``validate``, docs).

For a trace whose phone stated an accuracy (``accuracy``, or ``hdop`` times
the profile's ``scale_m``) and a profile with ``reported_accuracy``, each
simulated trace gets the model's errors and its stated radius at the
measured steps (the same gaps), and these statistics are compared:

* ``coverage``: the share of fixes whose true horizontal error lies inside
  the stated 68 % radius (0.68 for an honest phone; the phone's own over- or
  under-confidence is data);
* ``radius_median_m``, ``radius_q95_m``: the stated radius's level and spread;
* ``radius_changes_per_100``: how often the stated value changes between
  consecutive fixes (its persistence; 0 for a phone that states one value).

Each as measured, the simulated median and central 95 % range, and the
measured value's percentile among the simulations (ties count half).
"""

from typing import cast, Optional

import numpy as np

from gps_error_ros.fit.envelope import envelope
from gps_error_ros.model.protocol import ErrorModel, S
from gps_error_ros.model.reported import reference_cov, ReportedAccuracy
from gps_error_ros.model.stepping import run
from gps_error_ros.model.state import BoolArray, FloatArray, IntArray, Keys, Numbers
from gps_error_ros.traces.trace_io import Trace

MEASURES = ('coverage', 'radius_median_m', 'radius_q95_m', 'radius_changes_per_100')


def stated_radius(trace: Trace, reported: ReportedAccuracy,
                  rows: Optional[Numbers] = None) -> Optional[FloatArray]:
    """Return the trace's stated 68 % radius (m) at ``rows``, or None without the column."""
    col = trace.extra.get(reported.source)
    if col is None:
        return None
    col = np.asarray(col, dtype=float)
    col = col if rows is None else col[rows]
    return col * reported.scale_m if reported.source == 'hdop' else col


def _stats(err: FloatArray, radius: FloatArray, consecutive: BoolArray) -> dict[str, float]:
    """Return the measures of errors (n, 2) and stated radii (n,)."""
    ok = np.isfinite(radius)
    r = radius[ok]
    changes = np.diff(radius)[consecutive[1:] & ok[1:] & ok[:-1]]
    return {'coverage': float(np.mean(np.hypot(err[ok, 0], err[ok, 1]) <= r)),
            'radius_median_m': float(np.median(r)),
            'radius_q95_m': float(np.quantile(r, 0.95)),
            'radius_changes_per_100': float(100 * np.mean(changes != 0)) if changes.size
            else 0.0}


def _simulated_radius(model: ErrorModel[S], reported: ReportedAccuracy, keys: Keys,
                      span: int, steps: IntArray, sim: FloatArray) -> FloatArray:
    """Return each simulation's stated radius at ``steps``, (n, sims)."""
    x = reported.errors(keys, span)[steps, :, :]             # (n, sims, 1)
    if reported.follow == 0.0:
        return reported.radius(x)
    covs = run(model, keys, 0, span, cov=True).covariance    # the errors of model.simulate
    assert covs is not None
    return reported.radius(x, covs.transpose(1, 0, 2, 3)[steps], reference_cov(model))


def reported_check(model: ErrorModel[S], reported: ReportedAccuracy, trace: Trace,
                   rows: Numbers, steps: IntArray, measured: FloatArray, sim: FloatArray,
                   keys: Keys) -> Optional[dict[str, dict[str, float]]]:
    """
    Return the stated-accuracy measures, measured against simulated (see module doc).

    ``rows``: the trace rows of the measured errors ``measured`` (n, 2), at
    model ``steps`` (n,) from 0; ``sim`` (n, sims, 2) the simulated errors of
    streams ``keys``. None when the trace states nothing of the profile's source.
    """
    radius = stated_radius(trace, reported, rows)
    if radius is None or not np.isfinite(radius).any():
        return None
    consecutive = np.r_[False, np.diff(steps) == 1]
    meas = _stats(measured, radius, consecutive)
    sim_r = _simulated_radius(model, reported, keys, int(steps[-1]) + 1, steps, sim)
    per_sim = [_stats(sim[:, j], sim_r[:, j], consecutive) for j in range(keys.size)]
    out: dict[str, dict[str, float]] = {}
    for name in MEASURES:
        # a tie is the same value to YAML's 6 digits
        row = envelope(meas[name], [p[name] for p in per_sim], tol=1e-5)
        values = cast(dict[str, float], row)
        out[name] = {k: round(v, 1 if k == 'percentile' else 4) for k, v in values.items()}
    return out
