"""
The built-in profile of a low-cost snapshot receiver on foot, and its fit report.

Calibrates one profile from every SnapperGPS walk in ``--data``
(``snapper-walk-*.csv``), writes it to
``config/profiles/snapshot-receiver-on-foot.yaml``, and writes
``docs/walks.md``: each walk's gross failures, its fitted SD against its
robust SD, and the profile fitted without each walk validated on that walk
(leave one recording out), and what ``gps_error diagnose`` finds on each
walk. ``make walks-profile`` runs it (under a minute). The words are
``tools/templates/walks.md``.
"""

import argparse
import datetime as dt
import os
from pathlib import Path
import platform

import numpy as np
from data_sources import WALKS
from page_template import Template

from gps_error_ros.fit.calibration import calibrate
from gps_error_ros.fit.gross_failures import (find_gross_failures, robust_centre_scale,
                                              without_rows)
from gps_error_ros.fit.population_bias import time_constant_words
from gps_error_ros.fit.population_fit import occasions, population_line
from gps_error_ros.fit.validation import family_verdict, validate
from gps_error_ros.model.ar_model import ARErrorModel
from gps_error_ros.model.failures import failures_from_dict
from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.profiles import load_profile_file, profile_from_dict, write_profile
from gps_error_ros.traces.trace_io import read_trace_csv

NAME = 'snapshot-receiver-on-foot'
TEMPLATE = Template('walks')
#: Below this joint percentile a walk is unlike the profile's own traces (5 %).
UNLIKE = 5.0
#: A failure count whose one-sided tail is below this is outside the two-sided 95 %.
TAIL = 0.025
SIMS = 200
#: Traces per walk left out: its joint percentile near 5 needs more than SIMS to tell.
LEFT_OUT_SIMS = 1000


def _walk_rows(traces):
    """Return the per-walk table rows: failures and fitted SD against the robust SD."""
    rows = []
    for tr in traces:
        res = calibrate(tr)
        north, east = difference(tr.lat, tr.lon, tr.truth_lat, tr.truth_lon)
        near = np.hypot(north, east) <= 200.0
        sd = ARErrorModel(res.north.params, res.east.params).stationary_sd
        robust = [robust_centre_scale(v[near])[1] for v in (north, east)]
        f = res.failures[0]
        big = f'{f.size_m.max():.0f}' if f.count else '-'
        rows.append(f'| {tr.name} | {len(tr)} | {f.count} | {big} | '
                    f'{np.median(north[near]):.1f} / {np.median(east[near]):.1f} | '
                    f'{sd[0]:.1f} / {sd[1]:.1f} | {robust[0]:.1f} / {robust[1]:.1f} | '
                    f'{sd[0] / robust[0]:.2f} / {sd[1] / robust[1]:.2f} |')
    return rows


def _poisson_tail(count, expected):
    """Return the Poisson probability of a count at least as far from ``expected`` on its side."""
    from scipy import stats
    if count >= expected:
        return float(stats.poisson.sf(count - 1, expected))
    return float(stats.poisson.cdf(count, expected))


def split_row(row, k):
    """
    Return a Markdown table row as two: its first ``k`` cells, and the first with the rest.

    One table of every column is wider than the page at 1280 px.
    """
    cells = [c.strip() for c in row.strip().strip('|').split('|')]
    return ('| ' + ' | '.join(cells[:k]) + ' |',
            '| ' + ' | '.join(cells[:1] + cells[k:]) + ' |')


def _left_out_rows(traces, seed=1):
    """
    Return the leave-one-walk-out validation rows (the walk's occasion left out).

    And a sentence on the occasions as a family: the smallest joint
    percentile over the occasions (each occasion's the smallest of its
    walks'), Sidak-adjusted for their number.
    """
    rows, labels, joint, records = [], occasions(traces), [], []
    for i, tr in enumerate(traces):
        rest = [t for j, t in enumerate(traces) if labels[j] != labels[i]]
        res = calibrate(rest, population=True)
        prof = res.profile_dict('left-out')
        model = profile_from_dict(prof).model(gross_failures=False)
        found = find_gross_failures(tr)
        v = validate(model, without_rows(tr, found.mask), sims=LEFT_OUT_SIMS,
                     seed=seed).to_dict()
        section = prof.get('gross_failures')
        rate = section['rate'] if section else 0.0
        own = (failures_from_dict(section).count_tail(found.count, len(tr))
               if section and 'rate_sd_log' in section else float('nan'))
        n, e = v['north'], v['east']
        joint.append(v['shares_joint_percentile'])
        records.append({'walk': tr.name, 'joint': v['shares_joint_percentile'],
                        'failures': found.count, 'expected': rate * len(tr), 'own_tail': own})
        rows.append(f'| {tr.name} | {100 * n["acf_lags_inside_envelope"]:.0f} / '
                    f'{100 * e["acf_lags_inside_envelope"]:.0f} | '
                    f'{n["acf_share_percentile"]:.0f} / {e["acf_share_percentile"]:.0f} | '
                    f'{100 * n["quantiles_inside_envelope"]:.0f} / '
                    f'{100 * e["quantiles_inside_envelope"]:.0f} | '
                    f'{n["quantiles_share_percentile"]:.0f} / '
                    f'{e["quantiles_share_percentile"]:.0f} | '
                    f'{v["shares_joint_percentile"]:.1f} | '
                    f'{v["north"]["mean_m"]:.1f} / {v["east"]["mean_m"]:.1f} | '
                    f'{found.count} of {len(tr)} | {rate * len(tr):.1f} | '
                    f'{_poisson_tail(found.count, rate * len(tr)):.2g} | {own:.2g} |')
    fam = family_verdict(joint, labels)          # an occasion at its smallest
    note = TEMPLATE.snippet('family', occasions=fam['occasions'],
                            smallest=fam['smallest_percentile'],
                            probability=100 * fam['family_probability'],
                            verdict='unlike' if fam['unlike'] else 'not unlike')
    return rows, note, records, fam


def _diagnosis_rows(traces, seed=1):
    """Return per-walk rows of what ``gps_error diagnose`` finds, and each gain's interval."""
    from gps_error_ros.diagnose import diagnose
    from gps_error_ros.diagnose.common import DiagnosisError
    rows, gains = [], {}
    for tr in traces:
        found = find_gross_failures(tr)
        acf1 = [float(np.corrcoef(v[:-1], v[1:])[0, 1]) for v in _errors(tr, found.mask)]
        try:
            s = diagnose(tr, sims=SIMS // 2, seed=seed).findings     # failures left out
        except DiagnosisError as exc:
            rows.append(f'| {tr.name} | {acf1[0]:.2f} / {acf1[1]:.2f} | - | too short to '
                        f'diagnose alone ({str(exc).split(": ", 1)[1]}) | | |')
            continue
        imp = s.improvement
        gains[tr.name] = (imp.heldout_nll_per_sample, *imp.ci95)
        rows.append(f'| {tr.name} | {acf1[0]:.2f} / {acf1[1]:.2f} | '
                    f'{s.base.order["north"]} / {s.base.order["east"]} | '
                    f'{", ".join(s.effect_names) or "none"} | '
                    f'{", ".join(s.selection.kept) or "none"} | '
                    f'{imp.heldout_nll_per_sample:.3f} ({imp.ci95[0]:.3f} .. '
                    f'{imp.ci95[1]:.3f}) |')
    return rows, gains


def _heading_rows(traces, min_fixes=20):
    """
    Return per-walk rows of the median error by the direction the walker went.

    A body or a building beside the path could give an error that turns
    with the walker; a bias of the occasion stays where it is. The truth's
    velocity (differences over 7 s) sets the direction; fixes while the
    truth moves slower than 0.5 m/s, and gross failures, are left out.
    """
    rows = []
    for tr in traces:
        north, east = difference(tr.lat, tr.lon, tr.truth_lat, tr.truth_lon)
        tn, te = difference(tr.truth_lat, tr.truth_lon, tr.truth_lat[0], tr.truth_lon[0])
        box = np.ones(7) / 7
        vn, ve = (np.convolve(np.gradient(v, tr.t), box, mode='same') for v in (tn, te))
        keep = (np.hypot(vn, ve) > 0.5) & ~find_gross_failures(tr).mask
        sector = (np.round(np.degrees(np.arctan2(ve, vn)) / 90.0).astype(int)) % 4
        cells = []
        for k in range(4):
            m = keep & (sector == k)
            cells.append(f'{np.median(north[m]):+.1f} / {np.median(east[m]):+.1f} ({m.sum()})'
                         if m.sum() >= min_fixes else '-')
        speed = np.maximum(np.hypot(vn, ve), 1e-9)
        along = (north * vn + east * ve)[keep] / speed[keep]
        left = (north * ve - east * vn)[keep] / speed[keep]
        rows.append(f'| {tr.name} | ' + ' | '.join(cells) +
                    f' | {np.median(along):+.1f} / {np.median(left):+.1f} |')
    return rows


def _occasion_note(traces):
    """Return a paragraph on what the other occasions say of a shared walk left out."""
    from scipy import stats
    labels = occasions(traces)
    east = [float(np.median(_errors(t, find_gross_failures(t).mask)[1])) for t in traces]
    out = []
    for occ in sorted(set(labels)):
        members = [i for i, v in enumerate(labels) if v == occ]
        if len(members) < 2:
            continue
        others = {}
        for i, v in enumerate(labels):
            if v != occ:
                others.setdefault(v, []).append(east[i])
        k = len(others)
        lo, hi = (np.sqrt((k - 1) / stats.chi2.ppf(q, k - 1)) for q in (0.975, 0.025))
        walks = ', '.join(traces[i].name for i in members)
        bias = np.mean([east[i] for i in members])
        rest = [np.mean(v) for v in others.values()]
        # where the left-out bias falls in the predictive of a new draw from k
        t = (bias - np.mean(rest)) / (np.std(rest, ddof=1) * np.sqrt(1 + 1 / k))
        p_t = 2 * stats.t.sf(abs(t), k - 1)
        p_n = 2 * stats.norm.sf(abs(t))
        out += [TEMPLATE.snippet('occasion', walks=walks, bias=bias, others=k,
                                 other_biases=', '.join(f'{v:+.1f}' for v in rest),
                                 low=lo, high=hi, dof=k - 1, t=abs(t), p_t=p_t,
                                 p_normal=p_n), '']
    return out


def _two_scales_words(fit):
    """Return the words on how the fit split the walks' bias, or on why it did not."""
    pop = fit.population
    if pop is None or pop.run_bias_sd_m is None:
        return TEMPLATE.snippet('one-scale')
    held, wander = pop.run_bias_sd_m, pop.bias_sd_m
    ev = fit.evidence
    fitted = ev['wander_sd_estimate_m']
    return TEMPLATE.snippet('two-scales', held_north=held[0], held_east=held[1],
                            wander_north=wander[0], wander_east=wander[1],
                            time_constant=time_constant_words(ev), fitted_north=fitted[0],
                            fitted_east=fitted[1], contrasts=ev['wander_contrasts'])


def _summary(records, gains, fam):
    """Return the summary table's rows and its verdict."""
    rows, holding, misses = [], 0, []
    for r in records:
        holds = r['joint'] >= UNLIKE
        holding += holds
        if r['own_tail'] < TAIL:
            misses.append(r['walk'])
        gain = gains.get(r['walk'])
        said = '-' if gain is None else f'{gain[0]:.3f} ({gain[1]:.3f} to {gain[2]:.3f})'
        rows.append(f'| {r["walk"]} | {r["joint"]:.1f} | {"yes" if holds else "NO"} | '
                    f'{r["failures"]} ({r["expected"]:.1f}) | {r["own_tail"]:.2g} | {said} |')
    verdict = TEMPLATE.snippet(
        'verdict', holding=holding, walks=len(records),
        verdict='unlike' if fam['unlike'] else 'not unlike',
        tail_misses=', '.join(misses) or 'no walk',
        gains=sum(1 for g in gains.values() if g[1] > 0))
    return '\n'.join(rows), verdict


def _errors(tr, failed):
    """Return the walk's north and east errors without its gross failures, m."""
    north, east = difference(tr.lat, tr.lon, tr.truth_lat, tr.truth_lon)
    return north[~failed], east[~failed]


def main():
    """Write the profile and the report."""
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--data', default=str(Path(__file__).resolve().parents[1] / 'data'))
    p.add_argument('--out', default='.', help='the repository root')
    args = p.parse_args()
    paths = sorted(Path(args.data).glob(WALKS))
    if not paths:
        raise SystemExit(f'{args.data}: no {WALKS}')
    traces = [read_trace_csv(path) for path in paths]
    left_out, family, records, fam = _left_out_rows(traces)
    res = calibrate(traces, population=True)
    prof = res.profile_dict(
        NAME, 'a low-cost L1 snapshot receiver (SnapperGPS) carried on foot, Oxford',
        f'gps_error calibrate {" ".join(p.name for p in paths)} (SnapperGPS walks, '
        f'CC BY 4.0, J. Beuchert 2023, doi:10.5287/ora-xq5b8xva7)')
    dst = Path(args.out) / 'config' / 'profiles' / f'{NAME}.yaml'
    write_profile(dst, prof)
    load_profile_file(dst)
    north, east = res.axis_params
    sd = ARErrorModel(north, east).stationary_sd
    f = res.failure_process()
    diagnosis, gains = _diagnosis_rows(traces)
    summary_rows, summary_verdict = _summary(records, gains, fam)
    page = TEMPLATE.page(
        summary_rows=summary_rows, summary_verdict=summary_verdict, name=NAME,
        walks=len(paths), date=dt.date.today().isoformat(),
        machine=f'a {os.cpu_count()}-core {platform.machine()} machine (Python '
                f'{platform.python_version()})',
        north_order=north.order, east_order=east.order, sd_north=sd[0], sd_east=sd[1],
        mean_north=north.mean, mean_east=east.mean,
        population_line=population_line(res.population),
        failures=sum(x.count for x in res.failures), fixes=sum(x.rows for x in res.failures),
        smallest_m=f.sizes_m[0], largest_m=f.sizes_m[-1], rate=f.rate,
        rate_sd_log=f.rate_sd_log, recordings=len(res.failures),
        bias_parts=_two_scales_words(res.population),
        heading_rows='\n'.join(_heading_rows(traces)),
        walk_rows='\n'.join(_walk_rows(traces)), left_out_sims=LEFT_OUT_SIMS,
        left_out_rows='\n'.join(split_row(r, 7)[0] for r in left_out),
        left_out_failure_rows='\n'.join(split_row(r, 7)[1] for r in left_out), family=family,
        occasions='\n'.join(_occasion_note(traces)).strip(), diagnose_sims=SIMS // 2,
        diagnosis_rows='\n'.join(diagnosis))
    (Path(args.out) / 'docs' / 'walks.md').write_text(page)
    print(f'wrote {dst} and docs/walks.md')


if __name__ == '__main__':
    main()
