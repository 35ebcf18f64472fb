"""
Cross-validation of a profile against a measured trace (the paper's Sec. IV).

The profile simulates many traces with the measured trace's own time grid:
one continuous simulated series per Monte-Carlo run, sampled at the steps
where the measured trace has data, so gaps and segments match. Each
simulated trace is summarised exactly as the measured one, and the measured
statistics are compared with the Monte-Carlo envelope (the central 95 % of
the simulated values):

* autocorrelation per lag (pooled over segments), for the paper's Fig. 5; an
  envelope accounts for the large sampling spread of a persistent process's
  sample autocorrelation, where a fixed bound does not;
* quantiles of the errors per axis (QQ plot with envelope, Fig. 7);
* the share of lags and of quantiles inside the envelopes, beside the same
  share of each simulated trace (:func:`share_percentile`): what a trace of
  the model's own would show; and the four shares (two per axis) judged
  together (:func:`joint_share_percentile`), the one calibrated verdict on
  the trace;
* a map of truth, measured fixes and one simulated trace (Fig. 8; drawn by
  :mod:`gps_error_ros.reports.validation_figure`).
"""

from dataclasses import dataclass
import math
from typing import Any, Hashable, Mapping, Optional, Sequence

import numpy as np

from gps_error_ros.fit.autocorrelation import pooled_acf
from gps_error_ros.fit.calibration import errors_on_grid, GriddedErrors
from gps_error_ros.fit.envelope import outage_envelopes
from gps_error_ros.fit.gross_failures import without_rows
from gps_error_ros.fit.reported_check import reported_check
from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import AXES
from gps_error_ros.model.protocol import ErrorModel, S
from gps_error_ros.model.reported import ReportedAccuracy
from gps_error_ros.model.state import FloatArray, Keys, Numbers
from gps_error_ros.model.zoned import simulate_along
from gps_error_ros.traces.trace_io import Trace

QQ_PROBS = np.linspace(0.01, 0.99, 99)
#: The extra column that marks a trace's gross failures (1.0) for :func:`validate`.
FAILURE_COLUMN = 'gross_failure'


def slice_trace(trace: Trace, start_frac: float = 0.0, end_frac: float = 1.0) -> Trace:
    """Return the part of ``trace`` between two fractions of its duration."""
    t0, t1 = trace.t[0], trace.t[-1]
    lo, hi = t0 + start_frac * (t1 - t0), t0 + end_frac * (t1 - t0)
    m = (trace.t >= lo) & (trace.t <= hi) if end_frac >= 1.0 else \
        (trace.t >= lo) & (trace.t < hi)
    return Trace(trace.name, trace.t[m] - trace.t[m][0], trace.lat[m], trace.lon[m],
                 trace.truth_lat[m], trace.truth_lon[m],
                 {k: v[m] for k, v in trace.extra.items()})


@dataclass
class ValidationResult:
    """Measured statistics beside their Monte-Carlo envelopes."""

    name: str
    samples: int
    segments: int
    sims: int
    lags: np.ndarray
    acf: dict[str, Any]  # axis -> measured ACF (lags 0..L)
    acf_env: dict[str, Any]  # axis -> (3, L+1): 2.5 %, 50 %, 97.5 %
    quant: dict[str, Any]  # axis -> measured quantiles at QQ_PROBS
    quant_env: dict[str, Any]  # axis -> (3, len(QQ_PROBS))
    grid_steps: np.ndarray
    measured: np.ndarray   # (n, 2) errors
    simulated: np.ndarray  # (n, 2) one simulated error trace
    truth: tuple[Any, ...]  # (lat, lon) at the measured steps
    # outage statistics, measured against simulated
    availability: Optional[dict[str, Any]] = None
    # zone name -> the same checks on its samples (--zones)
    per_zone: Optional[dict[str, Any]] = None
    reported: Optional[dict[str, Any]] = None       # stated accuracy, measured against simulated
    # axis -> {'acf', 'quantiles'}: see share_percentile
    share_pct: Optional[dict[str, Any]] = None
    #: the four shares together (joint_share_percentile): set by validate, a percentage
    joint_pct: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        """Return the numbers behind the figures as plain data (``validation.json``)."""
        out: dict[str, Any] = {
            'input': self.name, 'samples': self.samples, 'segments': self.segments,
            'simulations': self.sims, 'max_lag': int(self.lags[-1]),
            'qq_probabilities': QQ_PROBS.tolist()}
        for ax in AXES:
            acf, env = self.acf[ax], self.acf_env[ax]
            q, qenv = self.quant[ax], self.quant_env[ax]
            out[ax] = {
                'acf_measured': np.round(acf, 4).tolist(),
                'acf_envelope_low': np.round(env[0], 4).tolist(),
                'acf_simulated_median': np.round(env[1], 4).tolist(),
                'acf_envelope_high': np.round(env[2], 4).tolist(),
                'acf_lags_inside_envelope': share_inside(acf[1:], env[:, 1:]),
                'acf_offset_rms_lags_1_10': float(np.sqrt(np.mean(
                    (acf[1:11] - env[1, 1:11]) ** 2))),
                'quantiles_measured_m': np.round(q, 3).tolist(),
                'quantiles_envelope_low_m': np.round(qenv[0], 3).tolist(),
                'quantiles_simulated_median_m': np.round(qenv[1], 3).tolist(),
                'quantiles_envelope_high_m': np.round(qenv[2], 3).tolist(),
                'quantiles_inside_envelope': share_inside(q, qenv),
                **({f'{k}_share_percentile': v for k, v in self.share_pct[ax].items()}
                   if self.share_pct else {}),
                'mean_m': float(self.measured[:, AXES.index(ax)].mean()),
                'sd_m': float(self.measured[:, AXES.index(ax)].std()),
            }
        if not math.isnan(self.joint_pct):
            out['shares_joint_percentile'] = self.joint_pct
        if self.availability is not None:
            out['availability'] = self.availability
        if self.per_zone is not None:
            out['zones'] = self.per_zone
        if self.reported is not None:
            out['reported_accuracy'] = self.reported
        return out

    def summary(self) -> str:
        """Return what the terminal shows: each check in a line, from :meth:`to_dict`."""
        return '\n'.join(summary_lines(self.to_dict()))


def summary_lines(doc: Mapping[str, Any]) -> list[str]:
    """Return a :meth:`ValidationResult.to_dict` document's checks, a line each."""
    lines = []
    for ax in AXES:
        d = doc[ax]
        lines.append(
            f'  {ax}: autocorrelation inside the envelope at '
            f'{100 * d["acf_lags_inside_envelope"]:.0f} % of lags 1-{doc["max_lag"]} '
            f'(percentile {d["acf_share_percentile"]:.0f} among the simulated traces\' own '
            f'shares); quantiles inside at {100 * d["quantiles_inside_envelope"]:.0f} % '
            f'(percentile {d["quantiles_share_percentile"]:.0f})')
    lines.append(f'  the four shares together: percentile {doc["shares_joint_percentile"]:.0f} '
                 'among the simulated traces (below 5: the trace is unlike the model\'s own '
                 'at the 5 % level)')
    for name, d in doc.get('reported_accuracy', {}).items():
        lines.append(f'  stated accuracy {name}: measured {d["measured"]:.4g}, simulated '
                     f'{d["sim_median"]:.4g} (95 % {d["sim_lo"]:.4g} to {d["sim_hi"]:.4g}), '
                     f'percentile {d["percentile"]:g}')
    for name, d in doc.get('zones', {}).items():
        if 'north' not in d:
            lines.append(f'  zone {name}: {d["samples"]} samples, too few to check on their '
                         f'own')
            continue
        lines.append(f'  zone {name}: {d["samples"]} samples; ' + '; '.join(
            f'{ax} ACF inside at {100 * d[ax]["acf_lags_inside_envelope"]:.0f} % of lags '
            f'1-{d[ax]["max_lag"]}, quantiles at '
            f'{100 * d[ax]["quantiles_inside_envelope"]:.0f} %, SD {d[ax]["sd_m"]:.2f} m '
            f'(simulated {d[ax]["sd_simulated_m"][0]:.2f}-{d[ax]["sd_simulated_m"][2]:.2f})'
            for ax in AXES))
    for name, d in doc['availability'].items():
        lines.append(f'  {name.replace("_", " ")}: measured {d["measured"]:g}, simulated '
                     f'median {d["sim_median"]:g} (95 % {d["sim_lo"]:g}-{d["sim_hi"]:g}), '
                     f'percentile {d["percentile"]:.0f}')
    return lines


def validate(model: ErrorModel[S], trace: Trace, sims: int = 200, max_lag: int = 60,
             seed: int = 0, zones: Any = None,
             reported: Optional[ReportedAccuracy] = None) -> ValidationResult:
    """
    Compare ``trace`` with ``sims`` traces simulated by ``model``.

    With ``reported`` (a profile's :class:`ReportedAccuracy`) and a trace
    that states its accuracy, the stated radius is compared too
    (:mod:`reported_check`; not with zones).

    With ``zones`` (``(ZoneMap, StepsPerFix)``) the traces follow the zone of
    the truth at every sample (:func:`~gps_error_ros.model.zoned.simulate_along`)
    and the checks are also made on each zone's samples alone (``per_zone``).

    Rows that the trace's extra column ``gross_failure`` marks (1.0) are
    left out of the error checks and count as fixes in the outage check.
    """
    with_failures = errors_on_grid(trace)
    failed = trace.extra.get(FAILURE_COLUMN)
    if failed is not None:
        trace = without_rows(trace, failed > 0.5)
    grid = errors_on_grid(trace)
    steps = np.concatenate([s + np.arange(len(seg)) for s, seg in
                            zip(grid.starts, grid.segments)])
    steps = steps - steps[0]
    measured = np.concatenate(grid.segments)
    max_lag = int(min(max_lag, max(len(s) for s in grid.segments) - 2))
    if max_lag < 1:
        raise ValueError(f'{trace.name}: segments too short to validate')
    keys = streams.agent_keys(seed, [f'validation/{i}' for i in range(sims)])
    bounds = np.cumsum([0] + [len(s) for s in grid.segments])
    per_zone = None
    if zones is None:
        sim = model.simulate(keys, int(steps[-1]) + 1)[steps]   # (n, sims, 2)
    else:
        zone = zones[0].lookup(trace.truth_lat[grid.rows], trace.truth_lon[grid.rows])
        sim = simulate_along(zones[1], keys, steps, zone)
        per_zone = zone_checks(measured, sim, steps, zone, zones[0].names, max_lag)
    lags = np.arange(max_lag + 1)
    acf, acf_env, quant, quant_env, share_pct = {}, {}, {}, {}, {}
    shares = []     # (measured share, simulated shares, envelope) of each check
    for a, ax in enumerate(AXES):
        meas_segs = [measured[b0:b1, a] for b0, b1 in zip(bounds[:-1], bounds[1:])]
        acf[ax] = pooled_acf(meas_segs, max_lag)
        sim_acf = np.array([
            pooled_acf([sim[b0:b1, j, a] for b0, b1 in zip(bounds[:-1], bounds[1:])],
                       max_lag) for j in range(sims)])
        acf_env[ax] = np.percentile(sim_acf, [2.5, 50, 97.5], axis=0)
        quant[ax] = np.quantile(measured[:, a], QQ_PROBS)
        sim_q = np.quantile(sim[:, :, a], QQ_PROBS, axis=0).T    # (sims, probs)
        quant_env[ax] = np.percentile(sim_q, [2.5, 50, 97.5], axis=0)
        share_pct[ax] = {
            'acf': share_percentile(acf[ax][1:], sim_acf[:, 1:], acf_env[ax][:, 1:]),
            'quantiles': share_percentile(quant[ax], sim_q, quant_env[ax])}
        shares += [(acf[ax][1:], sim_acf[:, 1:], acf_env[ax][:, 1:]),
                   (quant[ax], sim_q, quant_env[ax])]
    truth = (trace.truth_lat[grid.rows], trace.truth_lon[grid.rows])
    stated = None
    if reported is not None and zones is None:
        stated = reported_check(model, reported, trace, grid.rows, steps, measured, sim, keys)
    return ValidationResult(trace.name, grid.n, len(grid.segments), sims, lags,
                            acf, acf_env, quant, quant_env, steps, measured,
                            sim[:, 0, :], truth,
                            availability_check(model, with_failures, keys), per_zone, stated,
                            share_pct, joint_share_percentile(shares))


def share_percentile(measured: Numbers, simulated: Numbers, env: FloatArray) -> float:
    """
    Return the percentile of the measured share inside ``env`` among the simulated ones.

    The share of lags (or quantiles) inside pointwise 95 % envelopes is not
    a calibrated test on its own: one trace's values move together (a run's
    bias shifts all its quantiles at once), so a trace drawn from the model
    itself can have few inside. Each simulated trace's share against the
    same envelopes gives the share's law under the model; returned is the
    percentage of simulated traces whose share is at most the measured one
    (small: few of the model's own traces look as unlike it).

    ``measured`` (m,), ``simulated`` (sims, m), ``env`` (3, m): 2.5 %, 50 %,
    97.5 %.
    """
    return float(100.0 * np.mean(share_inside(simulated, env) <= share_inside(measured, env)))


def family_verdict(joint_percentiles: Sequence[float],
                   labels: Sequence[Hashable]) -> dict[str, Any]:
    """
    Return how recordings judged one by one fare together (Sidak over their occasions).

    ``joint_percentiles``: each recording's :func:`joint_share_percentile`;
    ``labels``: each recording's occasion (recordings made together, as
    :func:`~gps_error_ros.fit.population_fit.occasions` finds them, are one
    draw and count once, at the smallest of their percentiles). Among ``k``
    occasions drawn from the model, one as low as the smallest or lower
    turns up ``1 - (1 - p)^k`` of the time, ``p`` that percentile / 100.
    Returns ``{'occasions', 'smallest_percentile', 'family_probability',
    'unlike'}``; ``unlike`` at a family probability below 0.05.
    """
    by_occasion: dict[Hashable, float] = {}
    for pct, label in zip(joint_percentiles, labels):
        by_occasion[label] = min(by_occasion.get(label, 100.0), float(pct))
    k, low = len(by_occasion), min(by_occasion.values()) / 100.0
    family = 1.0 - (1.0 - low) ** k
    return {'occasions': k, 'smallest_percentile': 100.0 * low,
            'family_probability': family, 'unlike': bool(family < 0.05)}


def joint_share_percentile(checks: Sequence[tuple[Any, Any, Any]]) -> float:
    """
    Return the percentile of a trace's worst share percentile among the model's own traces.

    Each share percentile (:func:`share_percentile`) is a test at its own
    level; four of them on one trace reject a trace of the model's own more
    often than any one does. The smallest of the trace's percentiles is
    judged instead against the smallest of each simulated trace's own
    percentiles (each among all simulated traces, itself included), which
    accounts for however the checks move together. Returned is the
    percentage of simulated traces whose smallest percentile is at most the
    measured one: below 5, the trace as a whole is unlike the model's traces
    at the 5 % level.

    ``checks``: ``(measured, simulated, env)`` triples as for
    :func:`share_percentile`.
    """
    measured, simulated = [], []
    for meas, sims, env in checks:
        own = share_inside(sims, env)                          # (sims,)
        measured.append(100.0 * np.mean(own <= share_inside(meas, env)))
        simulated.append(100.0 * np.mean(own[None, :] <= own[:, None], axis=1))
    worst = np.min(simulated, axis=0)
    return float(100.0 * np.mean(worst <= min(measured)))


def share_inside(values: Numbers, env: FloatArray) -> Any:
    """Return the share of ``values`` (..., m) inside ``env`` (its first and last rows)."""
    inside = np.mean((values >= env[0]) & (values <= env[-1]), axis=-1)
    return float(inside) if np.ndim(inside) == 0 else inside


#: Fewest samples a zone needs for its own checks in ``validate --zones``.
MIN_ZONE_CHECK_SAMPLES = 60


def zone_checks(measured: FloatArray, sim: FloatArray, steps: Numbers, zone: Numbers,
                names: Sequence[str], max_lag: int) -> dict[str, Any]:
    """
    Return, per zone, the ACF and quantile checks on the zone's samples alone.

    A zone's samples are cut into segments wherever a step is missing or the
    walk left the zone; lags run to at most a third of the zone's longest
    segment (and ``max_lag``). Zones with fewer than
    :data:`MIN_ZONE_CHECK_SAMPLES` samples are listed with their count only.
    """
    names = list(names) + ['outside']
    out: dict[str, Any] = {}
    for z in np.unique(zone):
        idx = np.flatnonzero(zone == z)
        entry: dict[str, Any] = {'samples': int(idx.size)}
        out[names[z]] = entry
        if idx.size < MIN_ZONE_CHECK_SAMPLES:
            continue
        cuts = np.flatnonzero((np.diff(idx) > 1) | (np.diff(steps[idx]) > 1)) + 1
        segs = np.split(idx, cuts)
        lag = int(min(max_lag, max(len(g) for g in segs) // 3))
        for a, ax in enumerate(AXES):
            acf = pooled_acf([measured[g, a] for g in segs], lag)
            env = np.percentile([pooled_acf([sim[g, j, a] for g in segs], lag)
                                 for j in range(sim.shape[1])], [2.5, 97.5], axis=0)
            q = np.quantile(measured[idx, a], QQ_PROBS)
            qenv = np.percentile(np.quantile(sim[idx, :, a], QQ_PROBS, axis=0).T,
                                 [2.5, 97.5], axis=0)
            sd = sim[idx, :, a].std(axis=0)
            entry[ax] = {
                'max_lag': lag,
                'acf_lags_inside_envelope': share_inside(acf[1:], env[:, 1:]),
                'quantiles_inside_envelope': share_inside(q, qenv),
                'sd_m': float(measured[idx, a].std()),
                'sd_simulated_m': [float(v) for v in np.percentile(sd, [2.5, 50, 97.5])]}
    return out


def availability_check(model: ErrorModel[S], grid: GriddedErrors,
                       keys: Keys) -> dict[str, Any]:
    """
    Return outage statistics, measured (the trace's gaps) against simulated.

    Each simulated trace spans the measured one; a model without
    availability simulates none. Outages are counted by ``calibrate``'s rule
    on both sides (runs of 2 or more steps without a fix).
    """
    mask = grid.fix_mask()
    return outage_envelopes(mask, model.simulate_fix(keys, mask.size))
