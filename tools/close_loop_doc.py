"""
Regenerate ``docs/close-the-loop.md``: the diagnosis on every measured trace.

Run ``make close-the-loop-doc`` (or ``python tools/close_loop_doc.py
--data data --out docs``). For each trace CSV: ``diagnose`` (JSON,
figure and extended profile under ``docs/close-the-loop/``) and the model
classes of :mod:`baselines` on the same held-out samples. One seed of every
synthetic scenario is diagnosed as well, and the long blind run's summary
(``make diagnose-long``, ``bench_output/diagnose_long.json``) is included
when present (else the one kept from the last run). The words are the
templates ``tools/templates/close_loop.md`` and ``close_loop_traces.md``;
``--render`` (``make close-the-loop-page``) writes the page again from them
and the JSON already in ``docs/close-the-loop/``, without diagnosing.
"""

import argparse
import json
from pathlib import Path
import re

from close_loop_evidence import render_trace, run_evidence
from data_sources import CREDITS, WALKS

from gps_error_ros.diagnose import diagnose, DiagnosisError, extended_profile
from gps_error_ros.judge.baselines import CLASSES, compare, split_comparison
from gps_error_ros.fit.fidelity import binomial_interval
from gps_error_ros.model.profiles import write_profile
from gps_error_ros.reports.compare_figure import compare_figure
from gps_error_ros.reports.diagnosis_figure import diagnosis_figure
from gps_error_ros.sim.synthetic import PAIRS, SCENARIOS, synthetic_trace
from gps_error_ros.traces.trace_io import read_trace_csv

TEMPLATES = Path(__file__).with_name('templates')
TEMPLATE = TEMPLATES / 'close_loop.md'
TRACE_WORDS = TEMPLATES / 'close_loop_traces.md'
#: What the run keeps beside the traces' JSON: the synthetic walks, the
#: refusals and the long run's summary.
RECORDS = 'records.json'
SIMS = 100


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


def load(out_dir):
    """Return (records, synth, long_run) from the JSON a run left in ``out_dir``."""
    sub = Path(out_dir) / 'close-the-loop'
    kept = json.loads((sub / RECORDS).read_text())
    records = [{'trace': name, 'refused': why} for name, why in kept['refused'].items()]
    for path in sorted(sub.glob('*.json')):
        if path.name == RECORDS:
            continue
        doc = json.loads(path.read_text())
        records.append({'trace': path.stem + '.csv', 'summary': doc['diagnosis'],
                        'classes': doc['classes'], 'evidence': doc['evidence']})
    records.sort(key=lambda r: r['trace'])
    return records, kept['synthetic'], kept.get('long_run')


def save(out_dir, records, synth, long_run):
    """Write the run's :data:`RECORDS` (the traces' own JSON is written by :func:`run`)."""
    (Path(out_dir) / 'close-the-loop' / RECORDS).write_text(json.dumps(
        {'synthetic': synth, 'long_run': long_run,
         'refused': {r['trace']: r['refused'] for r in records if 'refused' in r}},
        indent=1) + '\n')


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


def trace_words(path=TRACE_WORDS):
    """Return {trace: {'caveat' | 'figure' | 'evidence': text}} from the traces' template."""
    words, trace, part = {}, None, None
    text = re.sub(r'<!--.*?-->', '', Path(path).read_text(), flags=re.S)
    for line in text.splitlines():
        if line.startswith('## '):
            trace, part = line[3:].strip(), None
            words[trace] = {}
        elif line.startswith('### ') and trace is not None:
            part = line[4:].strip()
            words[trace][part] = []
        elif part is not None:
            words[trace][part].append(line)
    return {t: {k: '\n'.join(v).strip() for k, v in parts.items()}
            for t, parts in words.items()}


def _synthetic(synth):
    """Return the synthetic walks' table."""
    md = ['| scenario | expected | found | kept | unexplained | held-out NLL before -> '
          'after (95 % CI of the gain) |', '|---|---|---|---|---|---|']
    for r in synth:
        exp = ', '.join(r['expected']) or ('unexplained' if r['expected_unexplained']
                                           else 'nothing')
        md.append(f'| {r["scenario"]} | {exp} | {", ".join(r["found"]) or "-"} | '
                  f'{", ".join(r["kept"]) or "-"} | '
                  f'{"; ".join(r["unexplained"]) or "-"} | {_f(r["before"])} -> '
                  f'{_f(r["after"])} ({_f(r["ci95"][0])} .. {_f(r["ci95"][1])}) |')
    return md


def _long_run(long_run):
    """Return the long blind run's paragraph and table (or how to get them)."""
    if not long_run:
        return ['(Run `make diagnose-long` and regenerate for the long blind '
                'run over a hundred seeds per effect-free scenario.)']
    cmd = long_run.get('command', 'make diagnose-long')
    md = [f'Long blind run (`{cmd}`, seeds from 1000, 1-hour walks; '
          f'{long_run["wall_s"]:.0f} s on this machine){long_run.get("note", "")}. In '
          f'brackets, the Clopper-Pearson 95 % interval of each share: 20 walks pin a '
          f'share of 90 % only to about 68-99 %.', '',
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
    return md + _pooled_rows(long_run['summary'])


def _rounded(value):
    """Return a parameter as text, its numbers to three significant figures."""
    if isinstance(value, (list, tuple)):
        return '[' + ', '.join(_rounded(v) for v in value) + ']'
    if isinstance(value, float):
        return f'{value:.3g}'
    return str(value)


def _trace(rec, words):
    """Return one measured trace's section."""
    name = rec['trace']
    what, credit = CREDITS.get(name, ('', 'see data/README.md'))
    md = [f'### {name}', '', f'{what}. Source and licence: {credit}.', '']
    if words.get('caveat'):
        md += [f'**Can it support a conclusion?** {words["caveat"]}', '']
    if 'refused' in rec:
        return md + [f'Not diagnosed: {rec["refused"]}', '']
    s = rec['summary']
    imp = s['improvement']
    ext = s['extended'].get('order', s['base']['order'])
    md += [f'{s["samples"]} samples: {s["train_samples"]} train, '
           f'{s["test_samples"]} held out ({s["scored_test_samples"]} '
           f'scored). Base orders: north {s["base"]["order"]["north"]}, '
           f'east {s["base"]["order"]["east"]}'
           + ('' if ext == s['base']['order'] else
              f'; extended: north {ext["north"]}, east {ext["east"]} (chosen without the '
              f'jumps)') + '.', '']
    md += _tests_table(s) + [''] + _effect_lines(s) + ['']
    eff = s['extended']['parameters'].get('effects', {})
    if eff:
        md += ['The fitted effects:', ''] + [f'- `{name}`: ' + ', '.join(
            f'{key} {_rounded(value)}' for key, value in params.items())
            for name, params in eff.items()] + ['']
    before = s['error_before']['heldout_nll_per_sample']
    after = s['error_after']['heldout_nll_per_sample']
    md += [f'Held-out NLL per sample: before {_f(before)}, after {_f(after)}; gain '
           f'{_f(imp["heldout_nll_per_sample"])} (95 % CI {_f(imp["ci95"][0])} .. '
           f'{_f(imp["ci95"][1])}).', '',
           f'![diagnosis of {name}](close-the-loop/{Path(name).stem}.png)', '']
    if words.get('figure'):
        md += [f'**Reading the figure.** {words["figure"]}', '']
    return md


def _classes(records):
    """Return the table of every class on every diagnosed trace, and their figures."""
    md = ['| trace | model class | held-out NLL | inside_95 | ACF distance | N-E correlation '
          '| q50 m | q95 m | q99 m |', '|---|---|---|---|---|---|---|---|---|']
    diagnosed = [rec for rec in records if 'classes' in rec]
    for rec in diagnosed:
        for label in CLASSES:
            md.append(_class_row(rec['trace'], label, rec['classes'][label]))
    md.append('')
    for rec in diagnosed:
        md += [f'![{rec["trace"]}: every class against the held-out part]'
               f'(close-the-loop/{Path(rec["trace"]).stem}.compare.png)', '']
    return md


def _evidence(records, words):
    """Return the experiments' tables of every diagnosed trace, with what they say."""
    md = []
    for rec in records:
        if 'evidence' in rec:
            md += render_trace(rec['trace'], rec['evidence'], rec['classes'])
            said = words.get(rec['trace'], {}).get('evidence')
            if said:
                md += [f'**What this says.** {said}', '']
    return md


def render(records, synth, long_run=None, template=TEMPLATE, traces=TRACE_WORDS):
    """Return the Markdown document: the template with its tables filled in."""
    words = trace_words(traces)
    blocks = {
        'SYNTHETIC': _synthetic(synth),
        'LONG_RUN': _long_run(long_run),
        'TRACES': [line for rec in records for line in _trace(rec, words.get(rec['trace'], {}))],
        'CLASSES': _classes(records),
        'EVIDENCE': _evidence(records, words)}
    text = Path(template).read_text()
    for key, lines in blocks.items():
        text = text.replace('{{' + key + '}}', '\n'.join(lines).strip())
    left = re.findall(r'{{\w+}}', text)
    if left:
        raise ValueError(f'{template}: no table for {left}')
    return text


def main(argv=None):
    """Entry point: regenerate the document and its figures (or, with --render, the page)."""
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--data', default=str(Path(__file__).resolve().parents[1] / 'data'))
    p.add_argument('--out', default='docs')
    p.add_argument('--long-run', default='bench_output/diagnose_long.json')
    p.add_argument('--sims', type=int, default=SIMS)
    p.add_argument('--render', action='store_true',
                   help='write the page from the templates and the JSON already there')
    args = p.parse_args(argv)
    if args.render:
        records, synth, long_run = load(args.out)
    else:
        kept = Path(args.out) / 'close-the-loop' / RECORDS
        long_run = json.loads(kept.read_text()).get('long_run') if kept.is_file() else None
        records, synth = run(args.data, args.out, args.sims)
        if Path(args.long_run).is_file():
            long_run = json.loads(Path(args.long_run).read_text())
        save(args.out, records, synth, long_run)
    doc = Path(args.out) / 'close-the-loop.md'
    doc.write_text(render(records, synth, long_run))
    print(f'wrote {doc}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
