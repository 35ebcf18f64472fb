"""
Calibrate a profile from measured errors: the paper's procedure, with gaps.

1. Errors are taken at the fixes' own stamps (north/east metres from the
   truth at the same instant) and placed on the model's grid by nearest step.
   Errors are never interpolated. A missing step is a gap, and gaps split the
   data into segments.
2. The autocovariance is pooled over segments (products only within a
   segment, about the pooled mean, divided by the total sample count: the
   biased estimator, so the Toeplitz matrix stays positive semi-definite).
3. The order is the paper's choice unless fixed: the largest lag up to
   ``max_order`` whose partial autocorrelation lies outside the significance
   bound ``z / sqrt(n)`` (z = 1.96, 5 %). BIC's choice is recorded beside it.
4. Yule-Walker gives phi and sigma_w; ``delta = (1 - sum phi) * mean``
   (Eq. 3). A non-stationary fit, or too few samples for the order, is refused.

Before step 1, each recording's gross failures (:mod:`gross_failures`: fixes
far from both the recording's median error and their neighbours) are taken
out, so the fit sees them as missing steps; they are counted in the ``fit``
section. Several recordings of one receiver give one profile: each keeps its
own segments (no product spans two recordings), the autocovariance is pooled
over all of them, and a recording too short for a fit alone still adds its
samples. Outages are counted within each recording.
"""

from dataclasses import dataclass, field
from typing import Any, Optional, Sequence

import numpy as np

from gps_error_ros.fit.accuracy_fit import estimate_reported
from gps_error_ros.fit.envelope import MIN_OUTAGE_STEPS
from gps_error_ros.fit.gross_failures import fit_rate_spread, GrossFailures, without_gross_failures
from gps_error_ros.fit.population_fit import (DAY_RATIO, fit_population, occasions,
                                              one_occasion_note, population_line,
                                              PopulationFit, segment_weights,
                                              with_day_allowance)
from gps_error_ros.fit.section_fit import SectionFit
from gps_error_ros.fit.velocity_fit import estimate_velocity
from gps_error_ros.fit.yule_walker import (AxisFit, CalibrationError,
                                           DEFAULT_MAX_ORDER, fit_axis)
from gps_error_ros.model.ar_model import ARErrorModel, AXES, AxisParams
from gps_error_ros.model.availability import runs_without_fix
from gps_error_ros.model.effect_schema import Effects
from gps_error_ros.model.failures import failures_from_sizes, GrossFailureProcess
from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.profiles import profile_mapping
from gps_error_ros.model.state import BoolArray, FloatArray, Numbers
from gps_error_ros.traces.trace_io import join_recordings, recordings_of, Trace

__all__ = ['AxisFit', 'calibrate', 'CalibrationError', 'CalibrationResult', 'check_sampling',
           'DEFAULT_MAX_ORDER', 'errors_on_grid', 'fit_axis', 'GriddedErrors']


@dataclass(frozen=True)
class GriddedErrors:
    """Errors on the model grid, split at gaps into segments."""

    segments: tuple[FloatArray, ...]
    starts: tuple[int, ...]
    rate_hz: float
    rows: Optional[np.ndarray] = None   # trace row of each sample, segments concatenated

    @property
    def n(self) -> int:
        """Return the total number of samples."""
        return int(sum(len(s) for s in self.segments))

    @property
    def span_s(self) -> float:
        """Return the time from the first to the last sample, in seconds."""
        last = self.starts[-1] + len(self.segments[-1]) - 1
        return (last - self.starts[0]) / self.rate_hz

    def axis(self, a: int) -> list[FloatArray]:
        """Return the segments of axis ``a`` (0 north, 1 east)."""
        return [s[:, a] for s in self.segments]

    def fix_mask(self) -> BoolArray:
        """Return, for every step from the first sample to the last, whether it has one."""
        first = self.starts[0]
        mask = np.zeros(self.starts[-1] + len(self.segments[-1]) - first, dtype=bool)
        for s, seg in zip(self.starts, self.segments):
            mask[s - first:s - first + len(seg)] = True
        return mask


#: The longest median interval between a recording's fixes, in model steps. Beyond
#: it most fixes have no fix on the next step, and the fits, which take products
#: of errors on neighbouring steps, have little or nothing to fit.
MAX_MEDIAN_INTERVAL_STEPS = 1.5


def check_sampling(trace: Trace, rate_hz: float = 1.0) -> None:
    """
    Refuse a recording whose fixes are mostly more than a model step apart.

    The :class:`CalibrationError` names the recording, its median interval
    and the longest one the grid at ``rate_hz`` takes.
    """
    if len(trace) < 2:
        return
    median = float(np.median(np.diff(trace.t)))
    if median * rate_hz > MAX_MEDIAN_INTERVAL_STEPS:
        raise CalibrationError(
            f'{trace.name}: its fixes are {median:.3g} s apart (median interval): the '
            f'model steps at {rate_hz:g} Hz and its fits use errors on neighbouring '
            f'steps, so they need fixes at {rate_hz:g} Hz or faster (a median '
            f'interval of at most {MAX_MEDIAN_INTERVAL_STEPS / rate_hz:g} s)')


def errors_on_grid(trace: Trace, rate_hz: float = 1.0) -> GriddedErrors:
    """Return the trace's north/east errors as :class:`GriddedErrors`."""
    north, east = difference(trace.lat, trace.lon, trace.truth_lat,
                             trace.truth_lon)
    pos = (trace.t - trace.t[0]) * rate_hz
    step = np.rint(pos).astype(np.int64)
    off = np.abs(pos - step)
    # Two fixes on one step: keep the one nearest the step's instant.
    order = np.lexsort((off, step))
    keep = order[np.r_[True, np.diff(step[order]) != 0]]
    step, err = step[keep], np.stack([north, east], axis=1)[keep]
    cuts = np.flatnonzero(np.diff(step) > 1) + 1
    segs = np.split(err, cuts)
    starts = np.split(step, cuts)
    return GriddedErrors(tuple(segs), tuple(int(s[0]) for s in starts),
                         float(rate_hz), keep)


def estimate_availability(grid: GriddedErrors,
                          min_outage_steps: int = MIN_OUTAGE_STEPS) -> SectionFit:
    """Return the availability section (or why none) from the gaps of ``grid``."""
    return availability_from_mask(grid.fix_mask(), min_outage_steps)


def availability_from_mask(mask: Numbers | Sequence[Numbers],
                           min_outage_steps: int = MIN_OUTAGE_STEPS) -> SectionFit:
    """
    Return the availability section (or why none) from a fix mask on the grid.

    ``mask`` may be a list of masks, one per recording: outages are counted
    within each, never across the time between two recordings.

    The outage rate is outages per step with a fix that has a next step
    (maximum likelihood for the profile's process); the durations are the
    outages' lengths in steps, as an empirical distribution. With no outage
    the section is None and the evidence gives the rate's 95 % upper bound
    (3 / steps, the rule of three).
    """
    masks = [np.asarray(m, dtype=bool) for m in
             (mask if isinstance(mask, (list, tuple)) else [mask])]
    gaps = [g for m in masks for g in runs_without_fix(m)]
    outages = [g for g in gaps if g >= min_outage_steps]
    n = int(sum(m.sum() for m in masks))
    chances = max(sum(max(int(m.sum()) - 1, 0) for m in masks), 1)
    evidence: dict[str, Any] = {
        'min_outage_steps': int(min_outage_steps), 'outages': len(outages),
        'dropped_steps': int(sum(g for g in gaps if g < min_outage_steps)),
        'steps_with_fix': n}
    if not outages:
        evidence['outage_rate_upper_95'] = round(3.0 / chances, 6)
        return SectionFit(None, evidence)
    lengths, counts = np.unique(outages, return_counts=True)
    durations: list[list[Any]] = [[int(k), round(float(c) / len(outages), 8)]
                                  for k, c in zip(lengths, counts)]
    total = sum(p for _, p in durations)
    durations[-1][1] = round(durations[-1][1] + 1.0 - total, 8)
    return SectionFit({'outage_rate': round(len(outages) / chances, 8), 'durations': durations},
                      evidence)


@dataclass(frozen=True)
class CalibrationResult:
    """A fitted profile and how it was obtained."""

    north: AxisFit
    east: AxisFit
    grid: GriddedErrors
    input: str
    velocity: SectionFit = field(default_factory=SectionFit.not_looked_for)
    reported: SectionFit = field(default_factory=SectionFit.not_looked_for)
    failures: tuple[GrossFailures, ...] = ()        # per recording
    # per recording, every grid step: a fix (failures too)
    fix_masks: Optional[tuple[BoolArray, ...]] = None
    population: Optional[PopulationFit] = None   # when asked for
    #: with a population: the extended model fitted within its blocks (axes,
    #: effects), set by :func:`~gps_error_ros.judge.population_calibration.calibrate_best`;
    #: None: the Gaussian AR of the population fit
    within: Optional[tuple[tuple[AxisParams, AxisParams], Effects]] = None

    @property
    def availability(self) -> SectionFit:
        """Return the availability section (or why none) from the recordings' gaps."""
        if self.fix_masks is None:
            return estimate_availability(self.grid)
        return availability_from_mask(list(self.fix_masks))

    def failures_summary(self) -> dict[str, Any]:
        """Return the gross failures of every recording as plain data."""
        return {'count': sum(f.count for f in self.failures),
                'fixes': sum(f.rows for f in self.failures),
                'recordings': {name: f.to_dict() for name, f in
                               zip(self.names, self.failures)}}

    @property
    def names(self) -> tuple[str, ...]:
        """Return the recordings' names."""
        return tuple(f.name for f in self.failures)

    @property
    def axis_params(self) -> tuple[AxisParams, AxisParams]:
        """Return the profile's (north, east) AR: the within process with a population."""
        if self.population is not None and self.population.population is not None:
            return self.population.axis_params() if self.within is None else self.within[0]
        return self.north.params, self.east.params

    @property
    def effects(self) -> Optional[Effects]:
        """Return the effects of the process within a population (None: a Gaussian AR)."""
        if self.within is None or self.population is None or self.population.population is None:
            return None
        return self.within[1]

    def summary(self, max_order: Optional[int] = None) -> str:
        """
        Return what ``gps_error calibrate`` prints of the fit: the data, each axis, the population.

        ``max_order``: the largest order the PACF could choose; an axis that
        reached it gets a note.
        """
        g = self.grid
        lines = [f'{self.input}: {g.n} samples in {len(g.segments)} segment(s), '
                 f'{g.span_s:.0f} s']
        axes = self.axis_params
        if self.effects is not None:
            orders = ', '.join(f'{ax} AR({p.order})' for ax, p in zip(AXES, axes))
            lines.append(f'  within the blocks: the extended model, {orders}, effects '
                         f'{", ".join(self.effects.names) or "none"} (the class that predicted '
                         f'best on held-out days; --within ar: the Gaussian AR)')
        else:
            sd = ARErrorModel(*axes).stationary_sd
            for i, (ax, fit) in enumerate(zip(AXES, (self.north, self.east))):
                p = axes[i]
                lines.append(f'  {ax}: AR({p.order}) (PACF chose {fit.pacf_order}, BIC '
                             f'{fit.bic_order}) delta={p.delta:.4f} '
                             f'phi={[round(v, 4) for v in p.phi]} sigma_w={p.sigma_w:.4f}; '
                             f'mean error {p.mean:.3f} m, stationary SD {sd[i]:.3f} m')
                if not fit.fixed_order and fit.pacf_order == max_order:
                    lines.append(f'  note: the {ax} PACF is significant up to the largest '
                                 f'order allowed (--max-order {max_order}); a larger '
                                 f'--max-order may choose more')
        if self.population is not None:
            lines.append(f'  {population_line(self.population)}')
            if one_occasion_note(self.population):
                lines.append(f'  note: {one_occasion_note(self.population)}')
        return '\n'.join(lines)

    def to_dict(self, name: str = 'calibrated') -> dict[str, Any]:
        """Return the fitted profile with its ``fit`` section, as plain data (the YAML's)."""
        return self.profile_dict(name)

    def profile_dict(self, name: str, description: Optional[str] = None,
                     source: Optional[str] = None) -> dict[str, Any]:
        """Return the profile (schema 1) with a ``fit`` section, as plain data."""
        availability = self.availability
        pop = self.population
        fit = {
            'method': 'Yule-Walker, biased autocovariance pooled over '
                      'segments',
            'input': self.input,
            'samples': self.grid.n,
            'segments': len(self.grid.segments),
            'time_span_s': float(self.grid.span_s),
            'order_selection': {ax: f.evidence() for ax, f in
                                zip(AXES, (self.north, self.east))},
            'availability': availability.evidence,
            'gross_failures': self.failures_summary(),
            'velocity': self.velocity.evidence,
            'reported_accuracy': self.reported.evidence}
        if pop is not None:
            fit['population'] = pop.evidence
        return profile_mapping(
            name, description or f'fitted to {self.input}',
            source or f'gps_error calibrate {self.input}',
            self.axis_params, rate_hz=self.grid.rate_hz, effects=self.effects, fit=fit,
            availability=availability.section, velocity=self.velocity.section,
            reported_accuracy=self.reported.section, gross_failures=self.failure_process(),
            population=None if pop is None else pop.population)

    def failure_process(self) -> Optional[GrossFailureProcess]:
        """
        Return the profile's ``gross_failures`` section fitted from every recording, or None.

        With a population (``calibrate --population``) and enough
        recordings, each agent's own rate: the recordings' counts differ
        between receivers more than one rate gives (:func:`fit_rate_spread`).
        """
        spread = None
        if self.population is not None and self.failures:
            spread = fit_rate_spread([f.count for f in self.failures],
                                     [f.rows for f in self.failures])
        return failures_from_sizes(sum(f.count for f in self.failures),
                                   sum(f.rows for f in self.failures),
                                   np.concatenate([f.size_m for f in self.failures])
                                   if self.failures else [], spread=spread)


def calibrate(trace: Trace | Sequence[Trace], order: Optional[int] = None,
              max_order: int = DEFAULT_MAX_ORDER, rate_hz: float = 1.0, population: bool = False,
              day_allowance: float = DAY_RATIO) -> CalibrationResult:
    """
    Fit both axes; return a :class:`CalibrationResult`.

    Parameters
    ----------
    trace
        One recording, or several of one receiver (see the module docstring).
    order
        The AR order of both axes (default: chosen per axis by the PACF).
    max_order
        The largest order the PACF may choose.
    rate_hz
        The model grid's rate.
    population
        Also fit a ``population`` section (:mod:`population_fit`): the AR
        becomes the process within blocks, the section how blocks and
        recordings differ (without enough blocks, no section, and the
        evidence says why).
    day_allowance
        For a population from one occasion: the SD of a part of the bias
        held for the run, as a ratio to the blocks' bias SD, an allowance
        for days the recording did not see
        (:func:`~.population_fit.with_day_allowance`); 0: none.

    Returns
    -------
    CalibrationResult

    Raises
    ------
    CalibrationError
        A recording sampled slower than the grid, too few samples for the
        order, constant or non-stationary errors.

    """
    traces = recordings_of(trace)
    for t in traces:
        check_sampling(t, rate_hz)
    kept, failures = without_gross_failures(traces)
    masks = tuple(errors_on_grid(t, rate_hz).fix_mask() for t in traces)
    clean = join_recordings(kept)
    grid = errors_on_grid(clean, rate_hz)
    fits = [fit_axis(grid.axis(a), order, max_order, axis=ax)
            for a, ax in enumerate(AXES)]
    pop = None
    if population:
        times = [(s + np.arange(len(seg))) / rate_hz
                 for s, seg in zip(grid.starts, grid.segments)]
        pop = fit_population(list(grid.segments), times, order, max_order,
                             weights=segment_weights(kept, times))
        pop.evidence['occasions'] = len(set(occasions(kept)))
        pop = with_day_allowance(pop, day_allowance)
    return CalibrationResult(fits[0], fits[1], grid, clean.name, estimate_velocity(clean),
                             estimate_reported(clean), tuple(failures), masks, pop)


#: Samples below which calibrate says how little data a fit had (ten minutes at 1 Hz).
LITTLE_DATA_SAMPLES = 600


def little_data_note(result: CalibrationResult) -> Optional[str]:
    """
    Return a note on a fit from little data, or None (``LITTLE_DATA_SAMPLES`` or more).

    It gives the span, the PACF's 95 % bound (lags whose partial
    autocorrelation is below it are not seen) and the orders PACF and BIC
    chose per axis: far apart, the order is uncertain.
    """
    g = result.grid
    if g.n >= LITTLE_DATA_SAMPLES:
        return None
    bound = result.north.pacf_bound
    orders = '; '.join(f'{ax} PACF {f.pacf_order}, BIC {f.bic_order}' for ax, f in
                       (('north', result.north), ('east', result.east)))
    return (f'{g.n} samples ({g.n / g.rate_hz / 60:.1f} min) is little data: the PACF '
            f'sees only partial autocorrelations beyond +-{bound:.3f}, and the orders '
            f'chosen ({orders}) are uncertain; fix one with --order, or record at '
            f'least {LITTLE_DATA_SAMPLES} samples')


#: Share of fixes in truth gaps, or of missing grid steps, that marks a
#: damaged stream (messages lost on the way, e.g. a replay too fast to take).
DAMAGE_SHARE = 0.01


def damage_note(grid: GriddedErrors, fixes_in: Optional[int] = None,
                in_truth_gap: int = 0) -> Optional[str]:
    """
    Return a warning when the data look damaged in transport, else None.

    Missing steps inside the span (gaps between segments) or fixes that fell
    into gaps of the truth, above :data:`DAMAGE_SHARE` of the samples, mean
    messages were lost: a fit goes ahead, but its ``sigma_w`` and ``phi``
    may be off, so the user is told.
    """
    span_steps = int(round(grid.span_s * grid.rate_hz)) + 1
    missing = span_steps - grid.n
    parts = []
    if missing > DAMAGE_SHARE * span_steps:
        parts.append(f'{missing} of {span_steps} steps missing '
                     f'({len(grid.segments)} segments)')
    if fixes_in and in_truth_gap > DAMAGE_SHARE * fixes_in:
        parts.append(f'{in_truth_gap} of {fixes_in} fixes in gaps of the truth')
    if not parts:
        return None
    return ('the data look damaged (' + '; '.join(parts) + '): messages were lost '
            'on the way; a replay should run slower, or check the recording')
