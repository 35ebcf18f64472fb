"""
Regenerate ``docs/close-the-loop.md``: the diagnosis on every measured trace.

Run ``make close-the-loop-doc`` (or ``python tools/close_loop_doc.py
--data data --out docs``). For each trace CSV: ``diagnose`` (JSON,
figure and extended profile under ``docs/close-the-loop/``) and the model
classes of :mod:`baselines` on the same held-out samples. One seed of every
synthetic scenario is diagnosed as well, and the long blind run's summary
(``make diagnose-long``, ``bench_output/diagnose_long.json``) is included
when present.
"""

import argparse
import json
from pathlib import Path

from close_loop_evidence import render_trace, run_evidence
from data_sources import CREDITS, WALKS

from gps_error_ros.diagnose import diagnose, DiagnosisError, extended_profile
from gps_error_ros.judge.baselines import CLASSES, compare, split_comparison
from gps_error_ros.diagnose.fidelity import binomial_interval
from gps_error_ros.model.profiles import write_profile
from gps_error_ros.reports.compare_figure import compare_figure
from gps_error_ros.reports.diagnosis_figure import diagnosis_figure
from gps_error_ros.sim.synthetic import PAIRS, SCENARIOS, synthetic_trace
from gps_error_ros.traces.trace_io import read_trace_csv

SIMS = 100

#: What each measured trace can and cannot support (from its README facts).
CAVEATS = {
    'gsdc2020-mtv1-pixel4.csv': 'a phone in a car on suburban roads and a '
    'highway, not a walking pedestrian: speeds up to ~30 m/s, open sky, '
    'decimetre-level errors. Effects found here are the phone\'s, but their '
    'sizes do not carry over to a pedestrian in a canyon.',
    'gsdc2020-mtv1-pixel4xlmodded.csv': 'the same drive with a second (modified) '
    'phone; the same caveat as the Pixel 4.',
    'urbannav-hk-tst-ublox-spp.csv': 'a dense urban canyon, but a slow car and '
    'a u-blox receiver\'s single-epoch least-squares fixes, not a phone\'s '
    'filtered output; 483 samples (one gross failure left out) give 338 for '
    'training and 145 held out, '
    'so the held-out interval is wide.',
    'gmt-static-phone-2016-08-22.csv': 'a static phone, 207 samples: too short '
    'for a split (the diagnosis needs 180 training and 80 held-out '
    'samples) and without motion, so no conclusion about pedestrians.',
}


#: What the figures show beyond the tests (read off them; kept with the data).
READINGS = {
    'gsdc2020-mtv1-pixel4.csv': 'the base model\'s squared innovations '
    'correlate every 4 s (red, lower right): the periodicity test finds an '
    '8-step cycle and the extended model, with one mean and one scale per '
    'phase, flattens it (green: inside the band but at lags 1 and 12). The '
    'innovations\' autocorrelation still dips at lags 8 and 28 s in the '
    'extended model (upper left): a serial correlation at the cycle\'s '
    'length that a cycle in the mean and the variance does not remove; the '
    'serial tests report it as unexplained. The tilted ellipse (north-east '
    'correlation about -0.6 in the innovations) is the clearest coupling in '
    'the data.',
    'urbannav-hk-tst-ublox-spp.csv': 'the squared innovations persist for '
    'tens of seconds (canyon stretches with very different satellite '
    'geometry): the regimes are the dominant effect, with three levels '
    'spanning a factor of about 25 in innovation SD.',
}


#: What the receiver_latency walks show of the motion lag's held-out gain.
LATENCY_NOTE = [
    'A motion lag moves the error mostly at stops and turns; on a 1-hour walk it is '
    'detected reliably, but its held-out gain is small (a few thousandths of a nat per '
    'sample) and rests on the few stops and turns of the held-out part. The synthetic '
    'latency wanders between 1.5 and 3 s and sits at one bound or the other for '
    'minutes, so the lag a training part supports need not be the held-out part\'s: '
    'on the long run\'s receiver_latency walks the lag fitted lies from 0.9 s below '
    'to 1.5 s above the training part\'s mean latency plus 0.3 s, and a walk whose '
    'held-out latency differs from its training part\'s can score worse after. Why '
    'the largest of the five likelihood ratios is referred to their joint law '
    '(max-T): [decision 0001](decisions/0001-max-t-motion-test.md).', '']


def _share(k, n):
    """Return 'k (lo-hi %)': a count with the Clopper-Pearson 95 % interval of its share."""
    lo, hi = binomial_interval(k, n)
    return f'{k} ({100 * lo:.0f}-{100 * hi:.0f} %)'


def _pooled_rows(summary):
    """Return the long-run table's rows of the shares pooled over the effect scenarios."""
    rows = {sc: v for sc, v in summary.items() if 'right' in v}
    fitted = [v for sc, v in rows.items() if SCENARIOS[sc][0]]
    if not rows:
        return []
    n, nb = sum(v['seeds'] for v in rows.values()), sum(v['seeds'] for v in fitted)
    return [f'| all effect scenarios | {n} | right attribution '
            f'{_share(sum(v["right"] for v in rows.values()), n)}; held-out NLL lower after '
            f'{_share(sum(v["after_better"] for v in fitted), nb)} of the {nb} walks with '
            f'an effect to fit |']


def _f(v, digits=3):
    return f'{v:.{digits}f}'


def run(data_dir, out_dir, sims=SIMS):
    """Diagnose every trace and every synthetic scenario; return the records."""
    data_dir, out_dir = Path(data_dir), Path(out_dir)
    sub = out_dir / 'close-the-loop'
    sub.mkdir(parents=True, exist_ok=True)
    records = []
    for csv_path in sorted(data_dir.glob('*.csv')):
        if csv_path.match(WALKS):      # diagnosed walk by walk in walks.md
            continue
        trace = read_trace_csv(csv_path)
        stem = csv_path.stem
        rec = {'trace': csv_path.name, 'rows': len(trace)}
        try:
            diag = diagnose(trace, sims=sims)
        except DiagnosisError as exc:
            rec['refused'] = str(exc)
            records.append(rec)
            continue
        rec['summary'] = diag.to_dict()
        rec['classes'] = compare(diag, sims=sims)
        rec['evidence'] = run_evidence(diag.fitted, trace, sims)
        compare_figure(split_comparison(csv_path.name, diag.split, rec['classes'],
                                        sims).to_dict(), sub / f'{stem}.compare.png')
        (sub / f'{stem}.json').write_text(json.dumps(
            {'diagnosis': rec['summary'], 'classes': rec['classes'],
             'evidence': rec['evidence']}, indent=1))
        diagnosis_figure(diag, sub / f'{stem}.png', csv_path.name)
        write_profile(sub / f'{stem}.extended.yaml',
                      extended_profile(diag, f'{stem}-extended', csv_path.name),
                      'diagnose')
        records.append(rec)
    synth = []
    for sc, (expected, unexplained) in SCENARIOS.items():
        if sc in PAIRS:             # the pairs are in the long run only
            continue
        s = diagnose(synthetic_trace(sc, 1, 3600), sims=30).to_dict()
        synth.append({'scenario': sc, 'expected': list(expected),
                      'expected_unexplained': unexplained,
                      'found': [e['name'] for e in s['effects']],
                      'kept': s['selection'].get('kept', []),
                      'unexplained': [u['structure'] for u in s['unexplained']],
                      'before': s['error_before']['heldout_nll_per_sample'],
                      'after': s['error_after']['heldout_nll_per_sample'],
                      'ci95': s['improvement']['ci95']})
    return records, synth


def _tests_table(s):
    lines = ['| test | statistic | p | Holm-adjusted p | rejected |',
             '|---|---|---|---|---|']
    for name, t in s['tests'].items():
        lines.append(f'| {name} | {t["statistic"]:.4g} | {t["p_value"]:.3g} | '
                     f'{t["holm_adjusted_p"]:.3g} | {"yes" if t["rejected"] else "no"}'
                     f'{" (with the jumps in)" if t.get("given") else ""} |')
    return lines


def _effect_lines(s):
    out = []
    for e in s['effects']:
        ev = e['evidence']
        extra = ''
        if 'levels' in ev:
            extra = f'; {ev["levels"]} levels chosen by BIC ({ev["chosen"]})'
        if 'reason' in ev:
            extra += f'; {ev["reason"]}'
        out.append(f'- **{e["name"]}**: test `{ev["test"]}`, Holm-adjusted p = '
                   f'{ev.get("holm_adjusted_p", float("nan")):.3g}{extra}.')
    if not out:
        out.append('- no effect attributed: the base model stands.')
    for alt in s['alternatives_rejected']:
        bic = ', '.join(f'{k} {v:.1f}' for k, v in alt.get('bic', {}).items())
        out.append(f'- rejected: **{alt["effect"]}**: {alt["reason"]} '
                   f'(training BIC: {bic}).')
    for u in s['unexplained']:
        lags = f', largest autocorrelation at lags {u["lags_largest"]}' \
            if 'lags_largest' in u else ''
        out.append(f'- unexplained ({u["stage"]}): {u["structure"]}{lags} '
                   f'(Holm-adjusted p = {u["holm_adjusted_p"]:.3g}).')
    for a in s.get('approximations', []):
        out.append(f'- left after the extended model: {a["structure"]} '
                   f'(Holm-adjusted p = {a["holm_adjusted_p"]:.3g}); '
                   f'{a["note"]} ({", ".join(a["effects"])}).')
    return out


def _class_row(trace, label, m):
    sim = m['horizontal_quantiles_simulated_m']
    q = m['horizontal_quantiles_m']
    d = m['nll_minus_best']
    gap = 'lowest' if d['mean'] == 0.0 else \
        f'{d["mean"]:+.3f}, {d["ci95"][0]:.3f} to {d["ci95"][1]:.3f}'
    return (f'| {trace} | {label} | {_f(m["heldout_nll_per_sample"])} ({gap}) | '
            f'{m["calibrated"]["inside_95"]:.2f} | '
            f'{_f(m["acf_distance"])} ({_f(m["acf_distance_simulated"]["median"])}) | '
            f'{_f(m["ne_correlation"], 2)} ({_f(m["ne_correlation_simulated"]["median"], 2)}) | '
            + ' | '.join(f'{q[k]:.2f} ({sim[k]["median"]:.2f}, {sim[k]["p2.5"]:.2f}-'
                         f'{sim[k]["p97.5"]:.2f})' for k in ('q50', 'q95', 'q99'))
            + ' |')


#: Where the pedestrian walks are diagnosed (their own page).
WALKS_NOTE = ('The pedestrian walks of a low-cost snapshot receiver (nearly white errors, '
              'a bias per walk, gross failures) are diagnosed walk by walk in '
              '[walks.md](walks.md), and judged left out one at a time in '
              '[generalisation.md](generalisation.md). Each trace\'s extended profile '
              '(`close-the-loop/<trace>.extended.yaml`, what `diagnose --profile-out` '
              'writes) describes the stretch it was fitted on; to simulate another drive, '
              'day or phone, each phone\'s population profile (`diagnose --profile-out '
              '--population`) is in `generalisation/`, validated on the other phone of the '
              'drive in [generalisation.md](generalisation.md#each-phones-profile-on-the-'
              'other-phone).')

#: Where the long run falls short, and where the choices behind it are recorded.
PAIRS_WITH_REFLECTIONS = [
    'Where the long run falls short of 90 %: none of the 15 effect scenarios. '
    'The pairs with `reflections` are the hardest: a reflection that wanders '
    'while it lasts, under a cycle, inflates the phase scales the reversal '
    'test sees, and its end can look like a large step that persists. '
    'engine_cycle+reflections ran 40 walks more (`python bench/diagnose_long.py '
    '--scenarios engine_cycle+reflections --effect-seeds 40 --first-seed 1020`): '
    '38 of 40 right; over its 60 walks 56 right, 93 % (95 % interval 84-98 %). '
    'The walks it gets wrong find the two effects and leave a persistence of '
    'the squares or a coupling that the same walk shows without its '
    'reflections. Why the procedure sets jumps aside before the law\'s tests, '
    'vetoes by the CRPS and tests the motion lag by max-T: the decision '
    'records in [decisions/](decisions/README.md).', '']


def render(records, synth, long_run=None):
    """Return the Markdown document."""
    md = ['# Closing the loop: what the AR model misses in measured data', '',
          '*Generated by `make close-the-loop-doc` '
          '(`python tools/close_loop_doc.py`); do not edit by hand.*',
          '',
          'The paper models each axis of a phone\'s position error as an '
          'independent AR(3) process with Gaussian innovations. '
          '`gps_error diagnose` looks for what that leaves in the one-step '
          'innovations, traces it to a physical effect, adds the effect and '
          'measures the error before and after on data the fit did not see. '
          'The procedure, every choice made on the training part alone '
          '(details in `gps_error_ros/diagnose/`):', '',
          '1. **Split** in time: the first 70 % of the time span trains, the '
          'last 30 % is held out and used once, to report. The first '
          'max(p, 5) samples of every segment are conditioned on and not '
          'scored, by every model.',
          '2. **Base model**: per axis AR(p), p by the PACF rule of '
          'calibration on the training part, independent Gaussian '
          'innovations.',
          '3. **Tests** on the base innovations, one family of ten, Holm\'s '
          'step-down procedure at a family-wise 3.33 % (ten fifteenths of the '
          'diagnosis\'s 5 %; the retest of step 6, at most five tests, has the '
          'rest): motion dependence '
          '(likelihood ratio of an error component b x (truth L s ago - truth '
          'now), L = 1..5 s, chi-bar-squared each; the largest against the law '
          'of the largest of the five correlated scores, max-T), lag-0 '
          'north-east correlation (heteroscedasticity-robust z), Mardia\'s '
          'bivariate kurtosis, persistence of the squares (Ljung-Box on the '
          'ranks of the squared Mahalanobis innovations, lags 1-10: ranks '
          'keep the level under heavy tails), the most negative of those '
          'autocorrelations (regimes and tails only make squares correlate '
          'positively: a negative one is periodic variance, `unexplained`) '
          'serial correlation per axis '
          '(heteroscedasticity-robust Ljung-Box, lags 1-30), the travel frame '
          '(does the innovation covariance turn with the direction of travel: '
          'the covariance of ((rn^2 - re^2)/2, rn re) with (cos 2theta, sin '
          '2theta), against the directions circularly shifted), periodicity '
          '(a cycle of P = 2-30 steps in the innovations\' mean or in the ranks '
          'of their squared radius: between-phase sums of squares, against '
          'blocks of 60 steps with their phases shifted at random, the largest '
          'standardised statistic over P) and jump reversal (a fix that jumps '
          'away and back leaves large innovations of opposite directions at '
          'both ends: minus the sum of the cosines between large innovations '
          '(squared radius above the chi-squared 0.999 quantile in robust '
          'units) at most 10 samples apart, against random signs, exact for '
          'any symmetric law however its variance clusters; '
          '`gps_error_ros/diagnose/family.py`).',
          '4. **Attribution**: cross-axis correlation -> `cross_axis_coupling`; '
          'motion dependence -> `motion_lag` (the law is then tested on '
          'innovations with the lag removed). Travel frame -> fixed axes '
          '(`cross_axis_coupling`) against axes along/across the travel '
          '(`street_frame`), the training BIC deciding (a fixed ellipse whose '
          'elongation changes with the direction also turns the test); when '
          'the travel axes win, the law is tested in that frame (the serial '
          'tests stay north/east, where the AR part is fitted: turned along '
          'the travel, the innovations of an AR(10) fail them). Periodicity '
          '-> `periodic` at the divisor of the test\'s P with the lowest '
          'training BIC (a cycle of P steps is one of 2P too); when it rejects '
          'on its own, the law is tested on innovations without the cycle, '
          'and the reversal test on innovations scaled by the phases\' SDs '
          'from medians of squares (a jump of metres inflates the mean square '
          'of the phase it falls in, and the other phases\' bursts then stay '
          'large and pair at random). '
          'Jump reversal -> `outliers`, fitted by a filter that sets the '
          'jumps aside (the mean part predicts from the cleaned past; two '
          'states, clean and in a jump, each with its own estimate of the last '
          'offsets, and four transitions per step: clean goes on, a jump '
          'starts, goes on, ends; a jump whose offset has come back within '
          'about an innovation SD of zero ends; the '
          'jumps\' rate, length and size, with the tails\' dof, searched '
          'together over a grid refined around its best; '
          '`gps_error_ros/diagnose/jumps.py`); when a family rejects it, the '
          'one with the jumps set aside (at Holm\'s first step, alpha / m, it '
          'always does) or else the one with them in (its rejection '
          'then counts as a step already taken, and the rest step down over '
          'm - 1), '
          'the other tests run with the jumps set aside (the steps '
          'more likely in '
          'a jump than not and the one after each dropped, the segment broken '
          'there), so a jump '
          'does not pass for a heavy tail, and the motion test is taken again '
          'on the series with the jumps taken out (a few jumps of metres sway '
          'its Gaussian likelihood ratio); the models with `outliers` have the '
          'AR orders the PACF rule picks on that series (to the rule, a jump '
          'looks like a loss of persistence: on a library trace with AR(3) '
          'errors and jumps it picks orders 10 and 1, and 3 and 3 with the '
          'jumps out). '
          'Tails and '
          'regimes compete: both '
          'fatten the marginal tails, only regimes make the squares persist. '
          'With persistence, `variance_regimes`, the training BIC choosing '
          'among 2 levels, 3 levels, and 2 levels plus Student-t innovations '
          '(`heavy_tails` too); kurtosis without persistence: `heavy_tails`. '
          'Serial correlation is never forced onto an effect: `unexplained`.',
          '5. **Selection**: the tests say which structures the training '
          'innovations hold, not that a model with all of them simulates the '
          'phone better. Every subset of the attributed effects is scored by '
          'blocked cross-validation over the training part (three contiguous '
          'blocks, each scored by a model fitted on the other two) on '
          'the one-step NLL and on how 50 traces simulated along the block '
          'match its measures: the CRPS of each measure (E|X - y| - '
          'E|X - X\'|/2 over the simulated values; Gneiting and Raftery '
          '2007), divided by that measure\'s median spread E|X - X\'| over '
          'the candidates, averaged over the measures. The score is proper, '
          'so a simulator cannot win by being too wide, as it can on '
          '`inside_95` (a share of measures covered, still reported). The '
          'effects found stand unless the blocks agree against them: a '
          'subset that another beats on the CRPS by 10 % or more in every '
          'block is vetoed (the ratio of two simulation seeds of one model '
          'has a log SD of about 0.07 per block); a subset '
          'not vetoed with the '
          'lower NLL in every block replaces the effects found; if these are '
          'vetoed, the lowest NLL of the rest '
          '(`gps_error_ros/diagnose/selection.py`).',
          '6. **Extended model** with the effects kept; its own '
          'innovations are tested again (serial and cross correlation, '
          'persistence, PIT of the predictive radius; Holm at a family-wise '
          '1.67 %). What remains of a '
          'structure no attributed effect targets is `unexplained`. The two '
          'rounds\' levels sum to 5 % (Bonferroni), so the whole diagnosis '
          'reports structure that is not there with probability at most 5 %.',
          '',
          'Estimation is the same for every model: conditional quasi-maximum '
          'likelihood, the mean part (delta, phi, lag) by least squares, the '
          'innovation law (covariance, correlation, dof, regimes) by maximum '
          'likelihood (EM for the regimes). Measures on the held-out part: '
          'the one-step predictive negative log-likelihood of the 2-D error '
          'in metres per sample (a forward filter for the regimes), with a '
          'moving-block bootstrap (blocks of 30 samples) of the paired '
          'per-sample differences; and, against 100 traces simulated by the '
          'model along the held-out truth and grid, the autocorrelation '
          'distance (RMS over lags 1-30, both axes, from the simulated mean '
          'ACF), the lag-0 north-east correlation and the 50/95/99 % '
          'quantiles of the horizontal error, with the simulated spread.', '',
          '## Proof on data with an undeclared effect', '',
          'Synthetic walks (`gps_error synth`, `gps_error_ros/sim/synthetic.py`): '
          'a pedestrian on Manhattan\'s grid at 1 Hz with stops and turns, '
          'errors from an AR(3) of DS5-like persistence plus one effect (or a '
          'pair, `a+b`) made by a mechanism other than the fitted forms. The '
          'diagnosis is not told which. One seed per single-effect scenario '
          '(the same seed for all; `make test` runs these; the pairs are in '
          'the long run):', '',
          '| scenario | expected | found | kept | unexplained | held-out NLL before -> '
          'after (95 % CI of the gain) |', '|---|---|---|---|---|---|']
    for r in synth:
        exp = ', '.join(r['expected']) or ('unexplained' if r['expected_unexplained']
                                           else 'nothing')
        md.append(f'| {r["scenario"]} | {exp} | {", ".join(r["found"]) or "-"} | '
                  f'{", ".join(r["kept"]) or "-"} | '
                  f'{"; ".join(r["unexplained"]) or "-"} | {_f(r["before"])} -> '
                  f'{_f(r["after"])} ({_f(r["ci95"][0])} .. {_f(r["ci95"][1])}) |')
    md.append('')
    if long_run:
        cmd = long_run.get('command', 'make diagnose-long')
        note = long_run.get('note', '')
        md += [f'Long blind run (`{cmd}`, seeds from 1000, 1-hour '
               f'walks; {long_run["wall_s"]:.0f} s on this machine){note}. In brackets, '
               f'the Clopper-Pearson 95 % interval of each share: 20 walks pin a '
               f'share of 90 % only to about 68-99 %:', '',
               '| scenario | seeds | result |', '|---|---|---|']
        for sc, v in long_run['summary'].items():
            if 'false_alarms' in v:
                res = (f'false alarms {v["false_alarms"]} (bound {v["bound"]}: '
                       f'binomial at the 5 % level, 99 % quantile)')
            else:
                res = (f'right attribution {_share(v["right"], v["seeds"])}, kept for '
                       f'simulation {v.get("kept_right", "-")}, held-out NLL lower '
                       f'after {_share(v["after_better"], v["seeds"])}; found: '
                       + '; '.join(', '.join(f) or 'nothing' for f in v.get('found', [])))
            md.append(f'| {sc} | {v["seeds"]} | {res} |')
        md += _pooled_rows(long_run['summary'])
        md.append('')
    else:
        md += ['(Run `make diagnose-long` and regenerate for the long blind '
               'run over a hundred seeds per effect-free scenario.)', '']
    md += PAIRS_WITH_REFLECTIONS
    md += LATENCY_NOTE
    md += ['## Measured traces', '', WALKS_NOTE, '']
    for rec in records:
        name = rec['trace']
        what, credit = CREDITS.get(name, ('', 'see data/README.md'))
        md += [f'### {name}', '', f'{what}. Source and licence: {credit}.', '',
               f'**Can it support a conclusion?** {CAVEATS.get(name, "")}', '']
        if 'refused' in rec:
            md += [f'Not diagnosed: {rec["refused"]}', '']
            continue
        s = rec['summary']
        stem = Path(name).stem
        imp = s['improvement']
        md += [f'{s["samples"]} samples: {s["train_samples"]} train, '
               f'{s["test_samples"]} held out ({s["scored_test_samples"]} '
               f'scored). Base orders: north {s["base"]["order"]["north"]}, '
               f'east {s["base"]["order"]["east"]}'
               + ('' if s['extended'].get('order', s['base']['order']) == s['base']['order']
                  else f'; extended: north {s["extended"]["order"]["north"]}, east '
                       f'{s["extended"]["order"]["east"]} (chosen without the jumps)')
               + '.', '']
        md += _tests_table(s) + ['']
        md += _effect_lines(s) + ['']
        eff = s['extended']['parameters'].get('effects', {})
        if eff:
            md += ['Fitted effects: `' + json.dumps(eff) + '`', '']
        before = s['error_before']['heldout_nll_per_sample']
        after = s['error_after']['heldout_nll_per_sample']
        md += [f'Held-out NLL per sample: before {_f(before)}, '
               f'after {_f(after)}; gain '
               f'{_f(imp["heldout_nll_per_sample"])} (95 % CI {_f(imp["ci95"][0])} .. '
               f'{_f(imp["ci95"][1])}).', '',
               f'![diagnosis of {name}](close-the-loop/{stem}.png)', '']
        if name in READINGS:
            md += [f'Reading the figure: {READINGS[name]}', '']
    md += ['## Model classes on the same held-out data', '',
           'Each class fitted on the same training part and scored on the same '
           'held-out samples (see `gps_error_ros/judge/baselines.py`). Cells: the '
           'measured value, with the models\' simulated median (and 95 % range '
           'for the quantiles) in brackets; for the ACF distance the bracket '
           'is the median distance of a simulated trace from the simulated '
           'mean, i.e. what sampling alone gives. Lower NLL is better; its '
           'bracket holds the NLL minus the lowest class\'s, paired on the same '
           'held-out samples, and its 95 % interval (a moving-block bootstrap of '
           'the per-sample differences): an interval that holds 0 cannot tell '
           'the two classes apart. '
           'Simulations run along the held-out truth on its own time grid, '
           'gaps kept. `inside_95`: the share of the 67 measures of `gps_error '
           'compare` (autocorrelation at lags 1-30 per axis, north-east '
           'correlation, SD per axis, horizontal quantiles 50/68/95/99 %) whose '
           'measured value lies inside the simulated central 95 % range; a '
           'calibrated simulator has about 0.95. Most of the 67 are '
           'autocorrelations at long lags, which many classes pass; the figure '
           'of `gps_error compare --report` shows which measures fail.', '',
           '| trace | model class | held-out NLL | inside_95 | ACF distance | N-E correlation '
           '| q50 m | q95 m | q99 m |', '|---|---|---|---|---|---|---|---|---|']
    for rec in records:
        if 'classes' not in rec:
            continue
        for label in CLASSES:
            md.append(_class_row(rec['trace'], label, rec['classes'][label]))
    md += ['', 'White noise plus bias: CARLA, Gazebo. AR(1): a first-order '
           'Gauss-Markov process at 1 Hz (Webots). ARMA(1,1): a Gauss-Markov '
           'bias plus white noise (hector_gazebo_plugins, PX4). AR(3): the '
           'paper. AR(p): the PACF-chosen order. Extended: the diagnosis\'s '
           'model.', '']
    for rec in records:
        if 'classes' in rec:
            stem = Path(rec['trace']).stem
            md += [f'![{rec["trace"]}: every class against the held-out part]'
                   f'(close-the-loop/{stem}.compare.png)', '']
    md += _evidence_section(records)
    return '\n'.join(md)


def _evidence_section(records):
    md = ['## Why a model can predict better and simulate worse', '',
          'The held-out NLL scores one step ahead, given the measured past; '
          '`inside_95` scores whole simulated traces. Four explanations, each '
          'with an experiment (`gps_error_ros/diagnose/evidence.py`): the '
          'trace is not stationary (blocks of the training part and the '
          'held-out part differ by more than sampling moves them; the '
          'direction of the split changes the ranking); an effect that helps '
          'one step ahead costs fidelity in simulation (every subset of the '
          'effects found); the estimator of the AR part (least squares '
          'against Yule-Walker); and the sampling spread of the measures '
          'themselves (the simulated range beside each).', '']
    for rec in records:
        if 'evidence' in rec:
            md += render_trace(rec['trace'], rec['evidence'], rec['classes'])
            if rec['trace'] in EVIDENCE_READINGS:
                md += [f'**What this says.** {EVIDENCE_READINGS[rec["trace"]]}', '']
    return md


#: What the evidence tables say, per trace (read off the generated tables).
EVIDENCE_READINGS = {
    'gsdc2020-mtv1-pixel4.csv':
    'Not stationary: the mean north error moves between -0.29 and 0.57 m '
    'from block to block, the north SD falls from 0.90 m (block 1) to 0.46 m '
    '(held out), and the motion lag each part alone fits ranges from 0.012 '
    'to 0.045 s. The effect that costs fidelity is `motion_lag`: every '
    'subset with it fails the short-lag autocorrelations and simulates a q95 '
    'of 2.09-2.35 m against 1.76 m measured; without it, '
    'cross_axis_coupling + variance_regimes + periodic has inside_95 1.00 '
    'and a held-out NLL of -0.755, against -0.764 and 0.93 with the lag '
    '(and 0.99 for AR(p)). The training part cannot see this: in the '
    'cross-validation the lag lowers the NLL (-0.088 to -0.139) and does not '
    'cost inside_95 (0.76 to 0.78), because the training blocks\' lag '
    '(0.024-0.045 s) is not the held-out part\'s (0.012 s), so the selection '
    'keeps it. The cycle is the largest single gain: periodic alone lowers '
    'the held-out NLL from -0.318 to -0.619 at no cost in fidelity. Held out '
    'the other way (first 30 %), the street frame replaces the fixed '
    'coupling and the extended model has both the lowest NLL (0.224 against '
    '0.537 for the paper\'s AR(3) and 0.678 for AR(p)) and the highest '
    'inside_95 (0.87 against 0.81): the ranking goes with the stretch held '
    'out. The estimator does not matter here (least squares and Yule-Walker '
    '0.99 both).',
    'gsdc2020-mtv1-pixel4xlmodded.csv':
    'The north-east correlation of the base innovations (-0.27) is not '
    'significant in the family of ten (Holm-adjusted p 0.073), so '
    '`cross_axis_coupling` is not found (with seven tests it was, at 0.042); '
    'the extended model\'s own innovations keep it (listed as unexplained). '
    'The selection keeps all the effects found, motion_lag, heavy_tails and '
    'variance_regimes: the lowest held-out NLL of all classes (-0.473) and '
    'inside_95 1.00. The motion lag again widens the simulated q95 (4.45 m '
    'against 3.30 m measured) but inside the envelope; its value is as '
    'unstable as on the Pixel 4 (0.000-0.075 s by block). Held out the '
    'other way, the extended model keeps the lowest NLL (0.164 against '
    '0.888-0.901 for the AR and ARMA classes) but not the highest inside_95 (0.91 '
    'against 0.94 for '
    'AR(p)).',
    'urbannav-hk-tst-ublox-spp.csv':
    'Not stationary beyond what sampling moves: the held-out median error '
    '(31.0 m) and north SD (20.9 m) lie outside the AR(p)\'s simulated '
    'ranges (10.2-16.5 m, 6.3-12.3 m), and the held-out mean north error is '
    '-20.1 m against -3.1 to 1.0 m in the training blocks, a bias the '
    'training part never shows. Even inside the training part the first '
    'block is no plausible draw of a model fitted on the other two '
    '(inside_95 0.10-0.16). The AR(3) and AR(p) reach inside_95 0.91 here '
    'because most of the 67 measures are autocorrelations: both miss the '
    'median, 68, 95 and 99 % errors and the north SD (the failing measures '
    'above), which no stationary class fitted on this training part covers. '
    'The regimes lower the NLL (6.91 against 7.57, the gap\'s 95 % interval '
    'holding 0: the class table) at a cost in fidelity (0.85 against 0.91). '
    'The estimator moves the short part\'s figures: Yule-Walker gives 0.84 '
    'against 0.91 by least squares, at an NLL of 7.52 against 7.57.',
}


def main(argv=None):
    """Entry point: regenerate the document and its figures."""
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--data', default=str(Path(__file__).resolve().parents[1] / 'data'))
    p.add_argument('--out', default='docs')
    p.add_argument('--long-run', default='bench_output/diagnose_long.json')
    p.add_argument('--sims', type=int, default=SIMS)
    args = p.parse_args(argv)
    records, synth = run(args.data, args.out, args.sims)
    long_run = None
    if Path(args.long_run).is_file():
        long_run = json.loads(Path(args.long_run).read_text())
    doc = Path(args.out) / 'close-the-loop.md'
    doc.write_text(render(records, synth, long_run))
    print(f'wrote {doc} and {Path(args.out) / "close-the-loop"}/')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
