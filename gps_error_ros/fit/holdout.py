"""
Step 1 of the diagnosis: the errors on the 1 Hz grid, cut in time.

The errors are taken as in calibration (at the fixes' stamps, never
interpolated; a missing step splits the data into segments), then the first
``TRAIN_FRACTION`` of the time span trains and the rest is held out. A
segment that straddles the cut becomes two.
"""

from dataclasses import dataclass
from typing import Optional

import numpy as np

from gps_error_ros.fit.calibration import errors_on_grid
from gps_error_ros.model.effect_schema import MOVING_M
from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.motion_lag import lag_offsets, RUN_GAP_S, truth_at
from gps_error_ros.model.state import BoolArray, FloatArray, Numbers
from gps_error_ros.traces.trace_io import recording_labels, Trace


#: Fraction of a trace's time span that trains; the rest is held out.
TRAIN_FRACTION = 0.7


@dataclass
class Part:
    """Errors, truth and timing of one part (train or test), by segment."""

    err: list[FloatArray]            # per segment (n_s, 2) north/east error, m
    truth: list[FloatArray]          # per segment (n_s, 2) truth north/east, local m
    t: list[FloatArray]              # per segment (n_s,) fix times, s
    #: per segment, the recording it belongs to (None: all one recording); what
    #: judges a part restarts at a recording's start and never pools across one
    recording: Optional[list[int]] = None

    @property
    def n(self) -> int:
        """Return the number of samples."""
        return int(sum(len(e) for e in self.err))

    def recordings(self) -> list[int]:
        """Return each segment's recording label (all 0 for one recording)."""
        return [0] * len(self.err) if self.recording is None else list(self.recording)

    def recording_starts(self) -> list[bool]:
        """Return, per segment, whether it is the first of its recording in the part."""
        labels = self.recordings()
        return [i == 0 or labels[i] != labels[i - 1] for i in range(len(labels))]


@dataclass(frozen=True)
class TruthTrack:
    """
    The truth of every fix of the trace (not only the gridded ones).

    A motion lag reaches back from a sample to the truth ``lag_s`` earlier,
    across the train/test cut and into steps the grid left out.
    """

    t: np.ndarray            # (n,) fix times, s
    north_east: np.ndarray   # (n, 2) truth north/east, local m


@dataclass(frozen=True)
class Split:
    """The two parts of a trace, the truth they share, and the rule."""

    train: Part
    test: Part
    truth: TruthTrack
    rule: str
    cut_time_s: float
    #: each training segment's weight in a population fit (None: 1 each;
    #: see :func:`~gps_error_ros.fit.population_fit.segment_weights`)
    train_weights: Optional[tuple[float, ...]] = None
    #: (training rows, held-out rows) as traces, where the trace has speed and
    #: course columns (:mod:`~gps_error_ros.judge.velocity_check`); else None
    velocity: Optional[tuple[Trace, Trace]] = None


def cut_trace(trace: Trace, cut_t: float | None = None, end_t: float = np.inf,
              train_fraction: float = TRAIN_FRACTION) -> tuple[Part, Part, TruthTrack, float]:
    """
    Return (train, test, truth, cut_s) of ``trace`` on the 1 Hz grid.

    ``train`` and ``test`` are :class:`Part`: the grid samples before
    ``cut_t`` and those in [``cut_t``, ``end_t``) (times are the trace's
    own, s; ``cut_t`` None: ``train_fraction`` of the grid's time span from
    its first sample); a segment starts anew at a grid gap or at the cut.
    ``truth`` is the :class:`TruthTrack` of every fix; ``cut_s`` the cut's
    time from the first grid sample.
    """
    grid = errors_on_grid(trace)
    if grid.rows is None:
        raise ValueError('errors_on_grid gave no trace rows: expected a row per grid sample')
    rows = grid.rows
    labels = recording_labels(trace)
    lat0, lon0 = float(trace.truth_lat[0]), float(trace.truth_lon[0])
    tn, te = difference(trace.truth_lat, trace.truth_lon, lat0, lon0)
    truth_all = np.stack([np.asarray(tn), np.asarray(te)], axis=1)
    err = np.concatenate(grid.segments)
    seg_id = np.concatenate([np.full(len(s), i) for i, s in enumerate(grid.segments)])
    t = trace.t[rows]
    if cut_t is None:
        cut_t = t[0] + train_fraction * (t[-1] - t[0])
    parts: list[Part] = []
    for sel in (t < cut_t, (t >= cut_t) & (t < end_t)):
        idx = np.flatnonzero(sel)
        brk = np.flatnonzero(np.diff(seg_id[idx]) != 0) + 1
        chunks = np.split(idx, brk) if idx.size else []
        parts.append(Part([err[c] for c in chunks], [truth_all[rows[c]] for c in chunks],
                          [t[c] for c in chunks], [int(labels[rows[c[0]]]) for c in chunks]))
    return parts[0], parts[1], TruthTrack(trace.t, truth_all), float(cut_t - t[0])


def split_trace(trace: Trace, train_fraction: float = TRAIN_FRACTION) -> Split:
    """Return the :class:`Split` of a trace on the 1 Hz grid."""
    train, test, truth, cut_s = cut_trace(trace, train_fraction=train_fraction)
    return Split(train, test, truth,
                 f'first {100 * train_fraction:.0f} % of the time span trains, '
                 f'the rest is held out', cut_s)


def like_windows(t: Numbers, span: float, gap_s: float = 60.0,
                 least: float = 0.8) -> list[BoolArray]:
    """
    Return boolean masks over ``t``: its stretches like a held-out part ``span`` s long.

    ``t`` (s, increasing) is cut into runs (no gap over ``gap_s``: its
    recordings); every window of ``span`` within a run, stepped by half of
    it and holding at least ``least`` of the samples such a window can hold
    at 1 Hz, and every run shorter than ``span`` whole, with 3 samples or
    more.
    """
    t = np.asarray(t, dtype=float)
    if t.size == 0:
        return []
    run = np.r_[0, np.cumsum(np.diff(t) > gap_s)]
    masks = []
    for r in range(run[-1] + 1):
        a, b = t[run == r][0], t[run == r][-1]
        whole = b - a < span
        for s0 in ([a] if whole else np.arange(a, b - span + 1e-9, max(span / 2.0, 1.0))):
            m = (t >= s0) & (t <= b) if whole else (t >= s0) & (t < s0 + span)
            if m.sum() < 3 or (not whole and m.sum() < least * (span + 1.0)):
                continue
            masks.append(m)
    return masks


def motion_offsets(part: Part, truth: TruthTrack | None, lag_s: float,
                   gain: float = 1.0) -> list[FloatArray]:
    """
    Return per segment ``gain * (truth(t - lag_s) - truth(t))``, (n_s, 2).

    ``truth`` is the whole trace's :class:`~.split.TruthTrack`, so a lag
    reaches back across the train/test cut, but not across a truth gap over
    :data:`RUN_GAP_S` (recordings joined one after another): there the
    truth is held at the later run's first sample. Without a motion term
    (``lag_s`` or ``gain`` 0) the truth is not needed (None).
    """
    if lag_s == 0.0 or gain == 0.0 or not part.t:
        return [np.zeros_like(e) for e in part.err]
    if truth is None:
        raise ValueError(f'a motion lag of {lag_s} s needs the truth: expected a TruthTrack')
    # one interpolation over every segment's times (each costs a pass over the truth)
    whole = lag_offsets(truth.t, truth.north_east[:, 0], truth.north_east[:, 1], lag_s,
                        at=np.concatenate(part.t), gap_s=RUN_GAP_S)
    out = np.split(whole, np.cumsum([len(t) for t in part.t])[:-1])
    return out if gain == 1.0 else [gain * o for o in out]


def travel_headings(truth: TruthTrack, times: Numbers, lag_s: float = 0.0) -> FloatArray:
    """
    Return the direction of travel (rad from north, clockwise) at ``times``.

    As the node's street frame: the truth's move over the second before
    ``times - lag_s``; where it moved less than ``MOVING_M`` the last
    direction (in the order of ``times``) holds, north before the first.
    The second never reaches back across a truth gap over :data:`RUN_GAP_S`.
    """
    times = np.asarray(times, dtype=float)
    now, back = (truth_at(truth.t, truth.north_east, when, RUN_GAP_S)
                 for when in (times - lag_s, times - lag_s - 1.0))
    dn, de = now[:, 0] - back[:, 0], now[:, 1] - back[:, 1]
    moving = np.hypot(dn, de) >= MOVING_M
    held = np.where(moving, np.arange(times.size), -1)
    held = np.maximum.accumulate(held) if held.size else held
    theta = np.arctan2(de, dn)
    return np.where(held >= 0, theta[np.maximum(held, 0)], 0.0)
