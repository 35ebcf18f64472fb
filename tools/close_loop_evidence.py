"""
The section of ``docs/close-the-loop.md`` that explains the contradiction.

Why can the extended model predict the held-out part better (NLL) and
simulate it worse (``inside_95``)? The experiments of
:mod:`gps_error_ros.diagnose.evidence`, run per measured trace by
``tools/close_loop_doc.py``, rendered here as tables.
"""

from page_template import Template

from gps_error_ros.diagnose import evidence
from gps_error_ros.judge.baselines import CLASSES, compare
from gps_error_ros.diagnose.pipeline import fit_split

#: Held-out measures shown per failing list.
SHOW_FAILING = 6
#: The tables' captions (tools/templates/close_loop_evidence.md).
WORDS = Template('close_loop_evidence')


def run_evidence(fitted, trace, sims):
    """Return the experiments' results for one fitted trace (plain data)."""
    out = {'blocks': evidence.block_statistics(fitted),
           'ablation': evidence.effect_ablation(fitted, sims),
           'estimator': evidence.estimator_check(fitted, sims),
           'spread': evidence.sampling_spread(fitted, sims),
           'selection': fitted.selection.to_dict(),
           'found': list(fitted.attribution.effects)}
    rev = fit_split(trace.name, evidence.reversed_split(trace))
    out['reversed'] = {k: {'heldout_nll_per_sample': v['heldout_nll_per_sample'],
                           'inside_95': v['calibrated']['inside_95']}
                       for k, v in compare(rev, sims=sims).items()}
    out['reversed_kept'] = list(rev.selection.kept)
    return out


def _v(x, d=2):
    return f'{x:.{d}f}'


def _eff(effects):
    return ', '.join(effects) or 'none (AR(p))'


def _failing(names):
    more = len(names) - SHOW_FAILING
    return ', '.join(names[:SHOW_FAILING]) + (f' and {more} more' if more > 0 else '') \
        if names else '-'


def render_trace(name, ev, forward):
    """Return the Markdown lines of one trace's evidence."""
    md = [f'### {name}', '', WORDS.snippet('blocks'), '',
          '| part | samples | mean N, E (m) | SD N, E (m) | motion lag alone (s) '
          '| median speed (m/s) |', '|---|---|---|---|---|---|']
    for r in ev['blocks']:
        md.append(f'| {r["part"]} | {r["samples"]} | {_v(r["mean_m"][0])}, '
                  f'{_v(r["mean_m"][1])} | {_v(r["sd_m"][0])}, {_v(r["sd_m"][1])} | '
                  f'{_v(r["motion_lag_s"], 3)} | {_v(r["median_speed_mps"], 1)} |')
    md += ['', WORDS.snippet('spread'), '',
           '| measure | training | held out | simulated 95 % range |', '|---|---|---|---|']
    for k, r in ev['spread'].items():
        md.append(f'| {k} | {_v(r["training"])} | {_v(r["held_out"])} | '
                  f'{_v(r["sim_lo"])} - {_v(r["sim_hi"])} |')
    md += ['', WORDS.snippet('reversed'), '',
           '| model class | held-out NLL, forward | inside_95, forward | '
           'held-out NLL, reversed | inside_95, reversed |', '|---|---|---|---|---|']
    for label in CLASSES:
        f, r = forward[label], ev['reversed'][label]
        md.append(f'| {label} | {_v(f["heldout_nll_per_sample"], 3)} | '
                  f'{_v(f["calibrated"]["inside_95"])} | '
                  f'{_v(r["heldout_nll_per_sample"], 3)} | {_v(r["inside_95"])} |')
    md += ['', WORDS.snippet('reversed-kept', effects=_eff(ev['reversed_kept'])), '']
    md += _ablation(ev)
    est = ev['estimator']
    md += [WORDS.snippet('estimator'), '',
           '| estimator | held-out NLL | inside_95 | failing measures |', '|---|---|---|---|']
    for k, r in est.items():
        md.append(f'| {k} | {_v(r["heldout_nll_per_sample"], 3)} | '
                  f'{_v(r["inside_95"])} | {_failing(r["failing"])} |')
    md.append('')
    return md


def _ablation(ev):
    found, kept = ev['found'], ev['selection'].get('kept', [])
    md = [WORDS.snippet('ablation'), '',
          '| effects | held-out NLL | inside_95 | q95 simulated (measured) m | '
          'failing measures |', '|---|---|---|---|---|']
    for r in ev['ablation']:
        tag = ' '.join(t for t, on in (('**found**', r['effects'] == found),
                                       ('**kept**', r['effects'] == kept)) if on)
        md.append(f'| {_eff(r["effects"])} {tag} | {_v(r["heldout_nll_per_sample"], 3)} '
                  f'| {_v(r["inside_95"])} | {_v(r["q95_sim_median"])} '
                  f'({_v(r["q95_measured"])}) | {_failing(r["failing"])} |')
    sel = ev['selection']
    md += ['', WORDS.snippet('selection'), '',
           '| effects | CV NLL | CV inside_95 | inside_95 by block | CRPS by block |',
           '|---|---|---|---|---|']
    for c in sel['candidates']:
        blocks = ', '.join(_v(v) for v in c['inside_95_by_block']) or c.get('failed', '')
        score = ', '.join(_v(v) for v in c.get('crps_by_block', [])) or '-'
        md.append(f'| {_eff(c["effects"])} | {_v(c["cv_nll_per_sample"], 3)} | '
                  f'{_v(c["cv_inside_95"])} | {blocks} | {score} |')
    if sel.get('note'):
        md.append(f'\nNote: {sel["note"]}')
    md.append('')
    return md
