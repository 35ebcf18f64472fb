"""
Is the held-out trace a plausible draw from the model? Simulate and compare.

A model simulates many traces along the held-out part's own truth and time
grid (same segments; a motion lag follows the truth), and the held-out
errors are summarised exactly as each simulated trace: the autocorrelation
per axis at lags 1..``FIDELITY_MAX_LAG``, the lag-0 north-east correlation
and the horizontal-error quantiles. Each measured value is reported with the
simulated median and central 95 % range beside it.
"""

from collections.abc import Mapping, Sequence
from typing import Any, Protocol, TypedDict

import numpy as np
from scipy import stats

from gps_error_ros.fit.autocorrelation import about_recording_means, segment_acf
from gps_error_ros.fit.envelope import envelope, inside, outage_envelopes
from gps_error_ros.fit.holdout import motion_offsets, Part, travel_headings, TruthTrack
from gps_error_ros.model import streams
from gps_error_ros.model.protocol import ErrorModel, S, StepInputs
from gps_error_ros.model.stepping import run
from gps_error_ros.model.state import BoolArray, FloatArray, IntArray, Keys, Numbers
from gps_error_ros.traces.trace_io import RECORDING_GAP_S

QUANTILES = (0.5, 0.95, 0.99)

#: Largest lag of the fidelity autocorrelation measures, s.
FIDELITY_MAX_LAG = 30


class Simulates(Protocol):
    """What :func:`simulate_part` needs of a class: its simulator and its mean's motion lag."""

    @property
    def mean(self) -> Any:
        """Return the class's mean part (its ``lag_s``: the motion lag, s)."""

    def simulator(self) -> Any:
        """Return the model the class simulates with."""


class Difference(TypedDict):
    """A mean difference of held-out scores, paired on the same samples, with its interval."""

    mean: float
    #: The 95 % interval (block bootstrap), [low, high].
    ci95: list[float]


def acf_by_axis(err_segments: Sequence[FloatArray], max_lag: int = FIDELITY_MAX_LAG,
                recording: Sequence[Any] | None = None) -> FloatArray:
    """
    Return the pooled ACF at lags 1..max_lag per axis, (max_lag, 2).

    ``recording``: each segment's recording; several recordings are each
    taken about their own mean (:func:`~.autocorrelation.about_recording_means`).
    """
    x = np.concatenate(about_recording_means(err_segments, recording))
    seg = np.concatenate([np.full(len(e), i) for i, e in enumerate(err_segments)])
    return np.stack([segment_acf(x[:, a], seg, max_lag) for a in range(2)], axis=1)


def measures(err_segments: Sequence[FloatArray], max_lag: int = FIDELITY_MAX_LAG,
             recording: Sequence[Any] | None = None) -> dict[str, Any]:
    """Return the fidelity measures of one error trace (list of segments; their recordings)."""
    x = np.concatenate(err_segments)
    h = np.hypot(x[:, 0], x[:, 1])
    return {'acf': acf_by_axis(err_segments, max_lag, recording),
            'corr': float(np.corrcoef(x.T)[0, 1]),
            'q': np.quantile(h, QUANTILES)}


def part_steps(part: Part) -> list[IntArray]:
    """
    Return each segment's steps on the 1 Hz grid, from the part's first sample.

    Within a segment samples are consecutive steps; the gaps between
    segments keep their measured length, so a simulation sampled at these
    steps has the data's gaps (a persistent process is not restarted at
    every gap).
    """
    t0 = part.t[0][0]
    return [int(round(t[0] - t0)) + np.arange(len(t)) for t in part.t]


def simulate_part(model: Simulates, part: Part, truth: TruthTrack, sims: int,
                  seed: int) -> list[list[FloatArray]]:
    """
    Return ``sims`` simulated error traces along ``part``'s truth and grid.

    One continuous run per trace and recording over the recording's span in
    the part, sampled at its steps (:func:`part_steps`): each recording is a
    run of its own, started from the model's stationary law as a new day's
    is (the streams' draws at its first step). A motion lag adds the
    offsets of the truth itself, and a street frame turns with the truth's
    direction of travel.
    """
    sim = model.simulator()
    keys = streams.agent_keys(seed, [f'sim{i}' for i in range(sims)])
    steps = part_steps(part)
    labels = part.recordings()
    x: dict[int, tuple[int, FloatArray]] = {}
    for rec in dict.fromkeys(labels):
        own = [s for s, lab in zip(steps, labels) if lab == rec]
        x[rec] = (int(own[0][0]), _run(sim, keys, int(own[0][0]), int(own[-1][-1]) + 1,
                                       truth, part.t[0][0], model.mean.lag_s))
    offs = motion_offsets(part, truth, model.mean.lag_s)
    return [[x[lab][1][s - x[lab][0], i] + o for s, o, lab in zip(steps, offs, labels)]
            for i in range(sims)]


def _run(sim: ErrorModel[S], keys: Keys, start: int, end: int, truth: TruthTrack,
         t0: float, lag_s: float) -> FloatArray:
    """Return one run's errors at model steps ``start .. end - 1``, (end - start, agents, 2)."""
    if not sim.needs_heading:
        return sim.simulate(keys, end - start, start=start)
    # street_frame: the innovations turn with the walk
    heading = travel_headings(truth, t0 + np.arange(start, end), lag_s)
    keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))

    def inputs(k: int) -> StepInputs:
        return StepInputs(heading=np.full(keys.size, heading[k - start]))
    return run(sim, keys, start, end - start, inputs=inputs).errors.transpose(1, 0, 2)


def fidelity(model: Simulates, part: Part, truth: TruthTrack, sims: int = 100, seed: int = 0,
             max_lag: int = FIDELITY_MAX_LAG) -> dict[str, Any]:
    """Compare the held-out errors with traces simulated along the truth."""
    return fidelity_of(part, simulate_part(model, part, truth, sims, seed), max_lag)


def _spread(v: Numbers) -> dict[str, float]:
    lo, mid, hi = np.quantile(v, [0.025, 0.5, 0.975])
    return {'median': float(mid), 'p2.5': float(lo), 'p97.5': float(hi)}


def fidelity_of(part: Part, simulated: Sequence[Sequence[FloatArray]],
                max_lag: int = FIDELITY_MAX_LAG) -> dict[str, Any]:
    """Return the fidelity measures of ``part`` against simulated traces."""
    sims = len(simulated)
    meas = measures(part.err, max_lag, part.recording)
    sim_m = [measures(s, max_lag, part.recording) for s in simulated]
    acfs = np.stack([m['acf'] for m in sim_m])
    centre = acfs.mean(axis=0)

    def rms(a: FloatArray) -> float:
        return float(np.sqrt(np.mean((a - centre) ** 2)))

    corr = np.array([m['corr'] for m in sim_m])
    qs = np.stack([m['q'] for m in sim_m])
    return {
        'acf_distance': rms(meas['acf']),
        'acf_distance_simulated': _spread([rms(a) for a in acfs]),
        'ne_correlation': meas['corr'],
        'ne_correlation_simulated': _spread(corr),
        'horizontal_quantiles_m': {f'q{int(100 * p)}': float(v) for p, v in
                                   zip(QUANTILES, meas['q'])},
        'horizontal_quantiles_simulated_m': {
            f'q{int(100 * p)}': _spread(qs[:, i]) for i, p in
            enumerate(QUANTILES)},
        'sims': sims,
    }


def block_bootstrap_mean(x: Numbers, seed: int = 0, block: int = 30,
                         reps: int = 2000) -> tuple[float, float, float]:
    """
    Return (mean, 2.5 %, 97.5 %) of ``x`` by a moving-block bootstrap.

    Each resample is ``n / block`` blocks (the last cut to make ``n``),
    summed from prefix sums: memory ``reps x blocks``, not ``reps x n``
    (a day's held-out part at 1 Hz made the index array 0.4 GB).
    """
    x = np.asarray(x, dtype=float)
    n = x.size
    block = max(1, min(block, n))
    rng = np.random.default_rng(seed)
    nb = -(-n // block)
    starts = rng.integers(0, n - block + 1, size=(reps, nb))
    cs = np.r_[0.0, np.cumsum(x)]
    last = n - (nb - 1) * block                 # the last block's length
    sums = (cs[starts[:, :-1] + block] - cs[starts[:, :-1]]).sum(axis=1) + \
        (cs[starts[:, -1] + last] - cs[starts[:, -1]])
    lo, hi = np.quantile(sums / n, [0.025, 0.975])
    return float(x.mean()), float(lo), float(hi)


def score_differences(lls: Mapping[str, Numbers], reference: str,
                      seed: int = 0) -> dict[str, Difference]:
    """
    Return each class's held-out NLL minus the reference class's, with a 95 % interval.

    ``lls``: ``{class: per-sample log densities}``, every class scored on
    the same samples. The paired per-sample differences are resampled by
    :func:`block_bootstrap_mean` (blocks of 30 samples keep the errors'
    persistence). Returns ``{class: {'mean', 'ci95': [lo, hi]}}``: a
    positive mean says the reference scores better; an interval that holds
    0 says the samples cannot tell the two apart.
    """
    ref = np.asarray(lls[reference], dtype=float)
    out: dict[str, Difference] = {}
    for label, ll in lls.items():
        ll = np.asarray(ll, dtype=float)
        if ll.shape != ref.shape:
            raise ValueError(f'{label}: scored on {ll.size} samples, the reference '
                             f'{reference} on {ref.size}; expected the same samples')
        mean, lo, hi = block_bootstrap_mean(ref - ll, seed=seed)
        out[label] = {'mean': mean, 'ci95': [lo, hi]}
    return out


def binomial_interval(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Return the Clopper-Pearson interval (lo, hi) of a share ``k`` of ``n``."""
    if n <= 0:
        raise ValueError(f'a share needs n > 0 trials, got n = {n}')
    a = (1.0 - level) / 2.0
    lo = float(stats.beta.ppf(a, k, n - k + 1)) if k > 0 else 0.0
    hi = float(stats.beta.ppf(1.0 - a, k + 1, n - k)) if k < n else 1.0
    return lo, hi


#: Horizontal-error quantiles of the calibrated measures.
CALIBRATED_QUANTILES = (0.5, 0.68, 0.95, 0.99)


def measure_vector(err_segments: Sequence[FloatArray], max_lag: int = FIDELITY_MAX_LAG
                   ) -> dict[str, float]:
    """
    Return the calibrated fidelity measures of one error trace, by name.

    The autocorrelation per axis at lags 1..``max_lag``, the lag-0
    north-east correlation, the SD per axis and the horizontal-error
    quantiles (50, 68, 95, 99 %).
    """
    x = np.concatenate(err_segments)
    acf = acf_by_axis(err_segments, max_lag)
    out = {}
    for a, ax in enumerate(('north', 'east')):
        for k in range(max_lag):
            out[f'acf_{ax}_lag{k + 1:02d}'] = float(acf[k, a])
    out['ne_correlation'] = float(np.corrcoef(x.T)[0, 1])
    out['sd_north'], out['sd_east'] = (float(v) for v in x.std(axis=0))
    h = np.hypot(x[:, 0], x[:, 1])
    for p, v in zip(CALIBRATED_QUANTILES, np.quantile(h, CALIBRATED_QUANTILES)):
        out[f'horizontal_q{int(round(100 * p))}'] = float(v)
    return out


def calibrated_fidelity(part: Part, simulated: Sequence[Sequence[FloatArray]],
                        max_lag: int = FIDELITY_MAX_LAG, draws: Any = None) -> dict[str, Any]:
    """
    Return whether the held-out ``part`` is a plausible draw of the simulations.

    For every measure of :func:`measure_vector`: the measured value, the
    simulated median and central 95 % range, and the measured value's
    percentile among the simulated ones (ties count half). ``inside_95`` is
    the share of measures inside their central 95 % range: near 0.95 for a
    calibrated simulator. ``draws``: the :func:`measure_draws` of ``part``
    and ``simulated`` when already computed.
    """
    names, y, x = draws or measure_draws(part, simulated, max_lag)
    out = {name: envelope(y[j], x[:, j]) for j, name in enumerate(names)}
    return {'inside_95': float(np.mean([inside(r) for r in out.values()])),
            'sims': len(simulated), 'measures': out}


def measure_draws(part: Part, simulated: Sequence[Sequence[FloatArray]],
                  max_lag: int = FIDELITY_MAX_LAG) -> tuple[list[str], FloatArray, FloatArray]:
    """
    Return the measures of ``part`` and of every simulated trace, as arrays.

    (names, measured (measures,), simulated (traces, measures)), the
    measures of :func:`measure_vector` in its order.
    """
    measured = measure_vector(part.err, max_lag)
    names = list(measured)
    sims = [measure_vector(s, max_lag) for s in simulated]
    return (names, np.array([measured[n] for n in names]),
            np.array([[m[n] for n in names] for m in sims]).reshape(len(sims), len(names)))


def part_fix_mask(part: Part) -> BoolArray:
    """Return the part's fix mask on the 1 Hz grid, first sample to last."""
    return _mask(np.concatenate(part_steps(part)))


def _mask(steps: IntArray) -> BoolArray:
    """Return the fix mask of grid steps from 0: True where a step has a fix."""
    mask = np.zeros(int(steps[-1]) + 1, dtype=bool)
    mask[steps] = True
    return mask


def run_masks(part: Part) -> list[BoolArray]:
    """
    Return the part's fix masks on the 1 Hz grid, one per recording.

    Recordings joined one after another (:func:`~gps_error_ros.traces.trace_io.join_recordings`)
    lie :data:`~gps_error_ros.traces.trace_io.RECORDING_GAP_S` apart, end to
    start: that time is no outage.
    """
    t = np.concatenate(part.t)
    joins = np.flatnonzero(np.abs(np.diff(t) - RECORDING_GAP_S) < 1e-6) + 1
    return [_mask(np.round(times - times[0]).astype(np.int64)) for times in np.split(t, joins)]


def with_outages(calibrated: Mapping[str, Any], part: Part,
                 masks: BoolArray | None) -> dict[str, Any]:
    """
    Add the outage measures to a :func:`calibrated_fidelity` result.

    ``masks``: the class's simulated fix masks over the part's span (sims,
    span), or None for a class without availability (it simulates a fix at
    every step). The outage measures (count, steps in outages, median and
    longest outage) join the measures and ``inside_95``.
    """
    mask = part_fix_mask(part)
    if masks is None:
        masks = np.ones((calibrated['sims'], mask.size), dtype=bool)
    out = dict(calibrated['measures'], **outage_envelopes(mask, masks))
    return dict(calibrated, measures=out,
                inside_95=float(np.mean([inside(r) for r in out.values()])))
