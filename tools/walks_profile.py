"""
The built-in profile of a low-cost snapshot receiver on foot, and its fit report.

Calibrates one profile from every SnapperGPS walk in ``--data``
(``snapper-walk-*.csv``), writes it to
``config/profiles/snapshot-receiver-on-foot.yaml``, and writes
``docs/walks.md``: each walk's gross failures, its fitted SD against its
robust SD, and the profile fitted without each walk validated on that walk
(leave one recording out), and what ``gps_error diagnose`` finds on each
walk. ``make walks-profile`` runs it (about two minutes).
"""

import argparse
import datetime as dt
from pathlib import Path
import platform

import numpy as np
from data_sources import WALKS

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


def _left_out_rows(traces, seed=1):
    """
    Return the leave-one-walk-out validation rows (the walk's occasion left out).

    And a sentence on the occasions as a family: the smallest joint
    percentile over the occasions (each occasion's the smallest of its
    walks'), Sidak-adjusted for their number.
    """
    rows, labels, joint = [], occasions(traces), []
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
    k = fam['occasions']
    note = (f'As a family, the {k} occasions (walks of one occasion taken at their smallest) '
            f'have their smallest joint percentile at {fam["smallest_percentile"]:.1f}: among '
            f'{k} occasions drawn from the model, one as low or lower turns up '
            f'{100 * fam["family_probability"]:.0f} % of the time (Sidak), so the walks '
            'together are ' + ('unlike' if fam['unlike'] else 'not unlike') +
            ' the model\'s traces at the 5 % level.')
    return rows, note


def _diagnosis_rows(traces, seed=1):
    """Return per-walk rows of what ``gps_error diagnose`` finds (its failures left out)."""
    from gps_error_ros.diagnose import diagnose
    from gps_error_ros.diagnose.common import DiagnosisError
    rows = []
    for tr in traces:
        found = find_gross_failures(tr)
        acf1 = [float(np.corrcoef(v[:-1], v[1:])[0, 1]) for v in _errors(tr, found.mask)]
        try:
            s = diagnose(tr, sims=SIMS // 2, seed=seed).findings     # failures left out
        except DiagnosisError as exc:
            rows.append(f'| {tr.name} | {acf1[0]:.2f} / {acf1[1]:.2f} | - | too short to '
                        f'diagnose alone ({str(exc).split(": ", 1)[1]}) | | |')
            continue
        imp = s['improvement']
        rows.append(f'| {tr.name} | {acf1[0]:.2f} / {acf1[1]:.2f} | '
                    f'{s["base"]["order"]["north"]} / {s["base"]["order"]["east"]} | '
                    f'{", ".join(e["name"] for e in s["effects"]) or "none"} | '
                    f'{", ".join(s["selection"]["kept"]) or "none"} | '
                    f'{imp["heldout_nll_per_sample"]:.3f} ({imp["ci95"][0]:.3f} .. '
                    f'{imp["ci95"][1]:.3f}) |')
    return rows


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
        out += [f'The walks of one occasion ({walks}: median east error {bias:+.1f} m), '
                f'left out together, are judged by what the other {k} occasions (median east '
                f'errors {", ".join(f"{v:+.1f}" for v in rest)} m) say of how biases spread: '
                f'from {k} occasions an SD is known only to within {lo:.1f}-{hi:.1f} times its '
                f'estimate (95 %). The population section therefore predicts a new '
                f'occasion\'s bias as Student-t with {k - 1} degrees of freedom (at least 3) '
                f'about a mean known to 1/sqrt({k}) '
                f'([decision](decisions/0009-a-new-occasions-bias.md)): this occasion\'s east '
                f'bias lies {abs(t):.1f} predictive scales from the others\' mean, a two-sided '
                f'tail of {p_t:.3f} under that law and of {p_n:.4f} under a normal of the '
                f'estimated SD. A receiver\'s profile needs recordings of more occasions than '
                f'this; more receivers on one walk add no occasion.', '']
    return out


def _two_scales_words(fit):
    """Return a sentence on how the fit split the walks' bias, or on why it did not."""
    pop = fit.population
    if pop is None or pop.run_bias_sd_m is None:
        return 'The fit keeps one part: the walks do not tell a held part from a wander.'
    held, wander = pop.run_bias_sd_m, pop.bias_sd_m
    ev = fit.evidence
    fitted = ev['wander_sd_estimate_m']
    return (f'The fit splits it in two ([decision](decisions/0024-a-bias-on-two-time-scales'
            f'.md)): a part held for the walk, SD {held[0]:.1f} m north and {held[1]:.1f} m '
            f'east (how the walks\' means differ), and a part that wanders within a walk, '
            f'{wander[0]:.1f} / {wander[1]:.1f} m with {time_constant_words(ev)} (how a '
            f'walk\'s 300-s blocks differ: '
            f'{fitted[0]:.1f} / {fitted[1]:.1f} m as fitted, predicted for a new walk from '
            f'{ev["wander_contrasts"]:.1f} contrasts of blocks within walks, '
            f'[decision](decisions/0025-the-wander-predicted-too.md)).')


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
    left_out, family = _left_out_rows(traces)
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
    lines = [
        '# Pedestrian walks: a snapshot receiver on foot',
        '',
        f'Measured on {platform.node() or "this machine"} ({platform.machine()}, '
        f'Python {platform.python_version()}), {dt.date.today().isoformat()}, with '
        '`make walks-profile` (`python tools/walks_profile.py --data data`).',
        '',
        f'The built-in profile `{NAME}` is fitted from the {len(paths)} SnapperGPS walks '
        'of `data/` together (`gps_error calibrate --population --within ar` with several '
        'recordings): '
        'a low-cost L1 snapshot receiver, each fix an independent single-epoch solution, '
        'carried on foot in Oxford with RTK truth.',
        '',
        f'- within blocks of 300 s: north AR({north.order}), east AR({east.order}); '
        f'stationary SD {sd[0]:.1f} m north, {sd[1]:.1f} m east; mean error '
        f'{north.mean:.1f} m north, {east.mean:.1f} m east.',
        f'- {population_line(res.population)}.',
        f'- gross failures: {sum(x.count for x in res.failures)} of '
        f'{sum(x.rows for x in res.failures)} fixes, '
        f'{f.sizes_m[0]:.0f} m to {f.sizes_m[-1]:.0f} m from the truth; each agent fails '
        f'at a rate of its own, log-normal with mean {f.rate:.4f} and log SD '
        f'{f.rate_sd_log:.2f} (maximum likelihood over the {len(res.failures)} '
        'recordings\' counts, each an agent).',
        '',
        '## What the receiver does, and how it differs from a phone',
        '',
        '- **Nearly white errors.** A snapshot fix does not filter: lag-1 autocorrelations '
        'are small (the PACF picks low orders on each walk alone), where a phone\'s fix '
        'is strongly persistent (lag 1 about 0.98 on the GSDC phones).',
        '- **A bias per walk, shared by the receivers on it.** The walks\' median errors '
        'differ by several metres (table below), while the three receivers carried on one '
        'walk (w03-w05) agree within half a metre: the bias belongs to the occasion (the '
        'sky, the place), not to the receiver. Pooled over walks about one mean, that '
        'difference shows as small positive autocorrelations at every lag (a fit without '
        '`--population` picks higher orders with small coefficients than any walk alone); '
        'the profile\'s `population` section describes it instead, as the spread of the '
        'occasions\' biases, each occasion counted once '
        '([decision](decisions/0007-occasions.md)). ' + _two_scales_words(res.population)
        + ' The bias does not turn with the '
        'walker: w03-w05\'s east error is -4 to -9 m whichever way they went (table '
        'below), so it is not the body or a wall beside the path but the occasion. A '
        'smaller part does turn with the walker: on six of the seven walks the median fix '
        'lies 1-4 m to the left of the track (the north error flips sign between going '
        'east and going west on w00-w02; on w03-w05 part of it is the east bias seen '
        'from legs that go north more often than south); the profile does not model it '
        '([decision](decisions/0019-no-offset-in-the-walkers-frame.md)).',
        '- **Gross failures.** Failed solutions hundreds of metres to kilometres off, often '
        'within a few fixes of good ones. The rule ([calibrating](calibrating.md), '
        '*Gross failures*) finds them '
        'relative to each walk\'s robust spread; they are kept out of the error fit and '
        'carried by the profile\'s `gross_failures` section. Their number differs from walk '
        'to walk far more than one rate gives (the Poisson tails under *Each walk left '
        'out*), and as much between the three receivers of w03-w05 as between walks: the '
        'propensity to fail is the receiver\'s (or where it was carried), not the '
        'occasion\'s. The section therefore gives each agent a rate of its own '
        '(`rate_sd_log`), drawn once for the receiver.',
        '',
        '## The bias and the direction walked',
        '',
        'Median error north / east (m) and fixes, by the direction the truth moved '
        '(within 45 degrees of north, east, south, west; moving at 0.5 m/s or more, gross '
        'failures left out; - for fewer than 20 fixes), and the median error along the '
        'track (ahead +) and to its left (+) over all of them.',
        '',
        '| walk | going north | going east | going south | going west | along / left (m) |',
        '|---|---|---|---|---|---|',
        *_heading_rows(traces),
        '',
        '## Each walk alone',
        '',
        'Fitted SD: the stationary SD of `gps_error calibrate` on the walk alone; robust SD: '
        '1.4826 x MAD of the errors after removing fixes beyond 200 m.',
        '',
        '| walk | fixes | gross failures | largest (m) | median error N / E (m) | '
        'fitted SD N / E (m) | robust SD N / E (m) | ratio N / E |',
        '|---|---|---|---|---|---|---|---|',
        *_walk_rows(traces),
        '',
        '## Each walk left out',
        '',
        'The profile fitted from the walks of other occasions (w03, w04 and w05 are one '
        'walk with three receivers: leaving out one, the other two are left out too), '
        'validated on the walk left out '
        f'(`gps_error validate`, {LEFT_OUT_SIMS} simulated traces, its gross failures left '
        'out on both sides): the share of autocorrelation lags 1-60 and of the 99 quantiles '
        'inside the simulated 95 % envelopes, each with its percentile among the same '
        'shares of the simulated traces themselves (one trace\'s quantiles move together '
        'with its bias, so a trace of the model\'s own can have few inside), the four '
        'shares judged together (the walk\'s smallest percentile against the smallest of '
        'each simulated trace\'s own: below 5 the walk is unlike the model\'s traces at '
        'the 5 % level; the smallest of four percentiles alone would reject a fifth of '
        'the model\'s own traces, [checking](checking.md)), the walk\'s mean error, and '
        'its failures against the number the profile\'s mean rate expects, with the '
        'probability of a count as far out on its side: Poisson at that rate (one rate '
        'for every receiver), and under the profile\'s rates of each agent\'s own '
        '(`rate_sd_log`, fitted from the other walks\' counts).',
        '',
        '| walk left out | ACF inside N / E (%) | its percentile | quantiles inside N / E (%) '
        '| its percentile | all four together | mean error N / E (m) | gross failures '
        '| expected | Poisson tail | tail, a rate per agent |',
        '|---|---|---|---|---|---|---|---|---|---|---|',
        *left_out,
        '',
        family,
        '',
        'Each simulated trace is another agent, with its own bias drawn from the '
        'population section: the profile covers walks whose biases differ by metres, '
        'which one fixed mean for all walks cannot. How every class fares on the walks '
        'left out, with a filter and a V2P warning as consumers: '
        '[generalisation.md](generalisation.md).',
        '',
        *_occasion_note(traces),
        '## What the diagnosis finds',
        '',
        f'`gps_error diagnose` on each walk, its gross failures left out ({SIMS // 2} '
        'simulated traces): the lag-1 autocorrelation of the errors, the base AR orders, '
        'the effects found and those the cross-validated selection keeps, and the held-out '
        'NLL improvement per sample with its 95 % interval. For comparison, the GSDC '
        'phones\' lag-1 autocorrelation is about 0.98 and their diagnosis is in '
        '[close-the-loop.md](close-the-loop.md).',
        '',
        '| walk | lag-1 ACF N / E | base orders N / E | effects found | kept | '
        'held-out NLL improvement |',
        '|---|---|---|---|---|---|',
        *_diagnosis_rows(traces),
        '',
        'A snapshot receiver\'s errors are nearly white: the lag-1 autocorrelation is '
        'small (the orders the PACF picks come with small coefficients), where a phone\'s '
        'filtered fix is strongly persistent. What the diagnosis finds instead is in the '
        'spread: heavy tails, variance that changes over the walk and, on some walks, '
        'north-east coupling. The failures rule leaves the bad estimates in (it removes '
        'what is not an estimate at all), and these effects describe them.',
        '']
    (Path(args.out) / 'docs' / 'walks.md').write_text('\n'.join(lines))
    print(f'wrote {dst} and docs/walks.md')


if __name__ == '__main__':
    main()
