"""
Speed and course on held-out data: a profile's ``velocity`` section, judged by speed band.

Where a trace carries the phone's and the reference's speed and course
(``speed``, ``bearing``, ``truth_speed``, ``truth_bearing``, as the GSDC
traces do), the section is fitted on the training rows
(:func:`~gps_error_ros.fit.velocity_fit.estimate_velocity`) and simulated
along the held-out rows' truth (its lags and error process, as
:meth:`~gps_error_ros.model.velocity.Velocity.report` gives the node's
``vel``). The measures, per band of the true speed (:data:`BANDS`): the
speed error's mean and SD (m/s) and the median absolute course error
(degrees), each judged inside the central 95 % of the simulated traces or
not. The velocity error is independent of the position error, so the
section, and this group, is the same for every class that carries it.
"""

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from gps_error_ros.fit.holdout import like_windows
from gps_error_ros.fit.envelope import envelope, Envelope, inside
from gps_error_ros.fit.velocity_fit import estimate_velocity, NEEDED, SLOW_TRUTH, vectors
from gps_error_ros.model import streams
from gps_error_ros.model.motion_lag import RUN_GAP_S, truth_at
from gps_error_ros.model.state import FloatArray, Numbers
from gps_error_ros.model.velocity import velocity_from_dict
from gps_error_ros.traces.trace_io import Trace

#: Bands of the true speed, m/s: walking and slow traffic, town, open road.
BANDS = ((1.0, 5.0), (5.0, 15.0), (15.0, np.inf))
#: Rows a band needs in the held-out part before it is judged.
MIN_ROWS = 30


def has_velocity(trace: Trace) -> bool:
    """Return whether ``trace`` has the speed and course columns the group needs."""
    return all(k in trace.extra for k in NEEDED)


def band_name(band: tuple[float, float]) -> str:
    """Return a band's label, e.g. ``5-15 m/s``."""
    lo, hi = band
    return f'{lo:g}+ m/s' if not np.isfinite(hi) else f'{lo:g}-{hi:g} m/s'


def _course_error(course: Numbers, truth_course: Numbers) -> FloatArray:
    """Return course errors wrapped into [-180, 180) degrees."""
    return (np.asarray(course) - np.asarray(truth_course) + 180.0) % 360.0 - 180.0


def band_measures(speed: Numbers, course: Numbers, truth_speed: Numbers,
                  truth_course: Numbers) -> dict[str, float]:
    """
    Return {measure name: value} of reported speeds and courses against the truth, by band.

    Per band of ``truth_speed`` with :data:`MIN_ROWS` rows or more:
    ``speed_mean``, ``speed_sd`` (the speed error's, m/s) and ``course_p50``
    (the median absolute course error, degrees, over rows with both courses).
    """
    out: dict[str, float] = {}
    truth_speed = np.asarray(truth_speed, dtype=float)
    err = np.asarray(speed, dtype=float) - np.asarray(truth_speed, dtype=float)
    cerr = np.abs(_course_error(course, truth_course))
    for band in BANDS:
        rows = (truth_speed >= band[0]) & (truth_speed < band[1]) & np.isfinite(err)
        if rows.sum() < MIN_ROWS:
            continue
        name = band_name(band)
        out[f'speed_mean {name}'] = float(np.mean(err[rows]))
        out[f'speed_sd {name}'] = float(np.std(err[rows]))
        c = cerr[rows & np.isfinite(cerr)]
        if c.size >= MIN_ROWS:
            out[f'course_p50 {name}'] = float(np.median(c))
    return out


def _truth_vectors(trace: Trace) -> FloatArray:
    """Return the reference's east/north velocity rows (NaN where unknown)."""
    ex = trace.extra
    return vectors(ex['truth_speed'], ex['truth_bearing'], zero_below=SLOW_TRUTH)


def velocity_group(train: Trace, test: Trace, sims: int = 100,
                   seed: int = 0) -> dict[str, Any] | None:
    """
    Return the group on one fold, or None where the traces cannot give it.

    ``train``, ``test``: the fold's training and held-out rows as traces.
    Returns ``{'section', 'measures': {name: envelope row (measured,
    sim_lo, sim_hi, ...)}, 'inside_95', 'train_windows'}`` (the measures
    over the training rows' stretches like the held-out rows:
    :func:`training_windows`; None: no speed and course columns, no section
    fitted on the training rows, or no band with enough held-out rows).
    """
    if not (has_velocity(train) and has_velocity(test)):
        return None
    section = estimate_velocity(train).section
    if section is None:
        return None
    vel = velocity_from_dict(section)
    ex = test.extra
    real = band_measures(ex['speed'], ex['bearing'], ex['truth_speed'], ex['truth_bearing'])
    if not real:
        return None
    truth = _truth_vectors(test)
    known = np.isfinite(truth).all(axis=1)
    t = test.t
    lagged = vel.truth_reported(*(truth_at(t[known], truth[known], t - lag, RUN_GAP_S)
                                  for lag in vel.lags))                 # not the run before
    steps = np.round(t - t[0]).astype(np.int64)
    keys = streams.agent_keys(seed, [f'velocity-check-{i}' for i in range(sims)])
    w = vel.errors(keys, int(steps[-1]) + 1)[steps]             # (rows, sims, 2)
    speed, course = vel.report(lagged[:, None, :], w)
    simulated = [band_measures(speed[:, k], course[:, k], ex['truth_speed'],
                               ex['truth_bearing']) for k in range(sims)]
    rows: dict[str, Envelope] = {}
    for name, value in real.items():
        values = np.array([s.get(name, np.nan) for s in simulated])
        rows[name] = envelope(value, values[np.isfinite(values)])
    return {'section': section, 'measures': rows,
            'inside_95': float(np.mean([inside(r) for r in rows.values()])),
            'train_windows': training_windows(train, float(t[-1] - t[0]), list(real))}


def training_windows(train: Trace, span: float, names: Sequence[str]) -> dict[str, Any]:
    """
    Return the range of each measure in ``names`` over the training rows' stretches of ``span`` s.

    Did the training rows ever look like the held-out ones? Each window of
    :func:`~gps_error_ros.fit.holdout.like_windows` is measured as the
    held-out rows are (:func:`band_measures`); a held-out value outside its
    measure's range has no precedent in training. Returns ``{'span_s',
    'windows', 'range': {name: [low, high]}}``, a measure no window had left
    out of ``range``.
    """
    ex = train.extra
    values = [band_measures(*(np.asarray(ex[k])[m] for k in
                              ('speed', 'bearing', 'truth_speed', 'truth_bearing')))
              for m in like_windows(train.t, span, RUN_GAP_S)]
    rng: dict[str, list[float]] = {}
    for name in names:
        got = [v[name] for v in values if name in v]
        if got:
            rng[name] = [float(min(got)), float(max(got))]
    return {'span_s': float(span), 'windows': len(values), 'range': rng}


def precedent(group: Mapping[str, Any]) -> tuple[list[str], list[str], list[str]]:
    """
    Return the group's measures outside their range: (all, without precedent, unmeasured).

    Without precedent: outside the range over the training rows' windows
    (``train_windows``) as well; unmeasured: no window had enough rows in
    the measure's band to say.
    """
    rng = (group.get('train_windows') or {}).get('range', {})
    miss = [k for k, r in group['measures'].items() if not inside(r)]
    new = [k for k in miss if k in rng and not rng[k][0] <= group['measures'][k]['measured']
           <= rng[k][1]]
    return miss, new, [k for k in miss if k not in rng]


def velocity_line(folds: Sequence[Mapping[str, Any]]) -> str | None:
    """
    Return a line on the group over ``folds`` (each with its ``velocity``), or None.

    The share inside, averaged over the folds that have the group, the
    measures outside their range on any of them, and those of them that
    lie outside every training window like the held-out rows on some fold
    (:func:`precedent`).
    """
    groups = [f['velocity'] for f in folds if f.get('velocity')]
    if not groups:
        return None
    share = float(np.mean([g['inside_95'] for g in groups]))
    found = [precedent(g) for g in groups]
    outside = sorted({name for miss, _, _ in found for name in miss})
    new = sorted({name for _, unseen, _ in found for name in unseen})
    return (f'  speed and course (the velocity section, the same for every class): '
            f'{share:.2f} inside over {len(groups)} fold(s)'
            + (f'; outside on some fold: {", ".join(outside)}' if outside else '')
            + (f'; of them without precedent in the training rows (outside every window '
               f'of theirs like the held-out rows): {", ".join(new)}' if new else ''))
