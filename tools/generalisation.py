"""
The generalisation table: every class judged on data its fit did not see.

Runs ``gps_error compare``'s fold comparison (:mod:`gps_error_ros.judge.generalise`)
on every visible recording set in ``--data``:

* every recording in ``--data`` but the walks, alone: rolling origin (one
  whose folds would hold out fewer than :data:`MIN_HELD_OUT` samples, or
  that cannot be read, is named under "Not judged" with the reason);
* the SnapperGPS walks: leave one walk out, and the walks recorded with it
  (another receiver on the same walk) out of its training;
* the two GSDC phones of one drive: each trains, the other is held out
  (another receiver); and each phone's extended and population profiles
  validated on the other phone (:mod:`phone_transfer`);

and writes ``docs/generalisation.md`` (with the JSON of every fold beside it
in ``docs/generalisation/``). ``make generalisation`` runs it (about 25
minutes on a 2-core machine).
"""

import argparse
import datetime as dt
import json
from pathlib import Path
import platform
import time

import numpy as np

from calm_stretches import calm_section
from data_sources import WALKS
from generalisation_text import LABELS
from page_template import Template
from phone_transfer import transfer, transfer_lines

from gps_error_ros.judge.beaten import gain_text, ORDER_GAIN
from gps_error_ros.judge.consumers import FILTER_PARTS
from gps_error_ros.judge.fold_summary import ERROR_GROUPS, precedent, summarise
from gps_error_ros.judge.generalise import (EXTRA_GROUPS, GROUPS, HORIZON, judge_folds,
                                            ORIGINS, recording_splits, rolling_splits,
                                            split_between)
from gps_error_ros.judge.velocity_check import precedent as velocity_precedent
from gps_error_ros.judge.window_persistence import spread_above
from gps_error_ros.fit.envelope import inside
from gps_error_ros.fit.gross_failures import find_gross_failures, without_rows
from gps_error_ros.fit.population_fit import MIN_BLOCK_SAMPLES
from gps_error_ros.model.velocity import velocity_from_dict
from gps_error_ros.traces.trace_io import join_recordings, read_trace_csv

#: The classes the GTSAM smoother judges (it adds a pose per sample: slow), and their traces.
SMOOTHER_CLASSES = ('white_bias', 'ar1', 'extended', 'population')
SMOOTHER_SIMS = 40
#: m/s: the speeds at which the velocity table reads a section's SD.
SPEEDS = (3.0, 10.0, 27.0)
PHONES = ('gsdc2020-mtv1-pixel4.csv', 'gsdc2020-mtv1-pixel4xlmodded.csv')
#: The rows of the phones' profiles validated on each other (phone_transfer.py).
TRANSFER_JSON = 'phone-transfer.json'
#: The sets in the page's order and the recordings not judged, as the fitting run found them.
PAGE_JSON = 'page.json'
WALK_SET, PHONE_SET = 'SnapperGPS walks', 'GSDC phones of one drive'
#: Held-out samples a rolling fold needs: one population block's worth.
MIN_HELD_OUT = MIN_BLOCK_SAMPLES
#: The page's words (tools/templates/generalisation.md).
TEMPLATE = Template('generalisation')


def _words(key, /, **fields):
    """Return a snippet of the template as one line (inside a list item or a sentence)."""
    return ' '.join(TEMPLATE.snippet(key, **fields).split())


def _clean(path):
    trace = read_trace_csv(path)
    return without_rows(trace, find_gross_failures(trace).mask)


def _cross(a, b):
    """Return the split: train on ``a``, hold out ``b`` (another receiver)."""
    joined = join_recordings([a, b])
    cut = float(joined.t[-len(b.t)])
    return (f'train {a.name}, test {b.name}',
            split_between(joined, cut, float(joined.t[-1]) + 1.0,
                          f'train on {a.name}, hold out {b.name}'))


def alone(data):
    """
    Return ([(name, trace)] judged alone by rolling origin, {name: why another is not}).

    Every trace in ``data`` but the walks, in name order, gross failures
    taken out.
    """
    walks = set(data.glob(WALKS))
    judged, not_judged = [], {}
    for path in sorted(data.glob('*.csv')):
        if path in walks:
            continue
        try:
            trace = _clean(path)
        except (ValueError, OSError) as exc:
            not_judged[path.name] = f'not read: {exc}'
            continue
        t = trace.t
        span = float(t[-1] - t[0])
        held = min(int(np.sum((t >= t[0] + o * span) & (t < t[0] + (o + HORIZON) * span)))
                   for o in ORIGINS)
        if held < MIN_HELD_OUT:
            not_judged[path.name] = f'{t.size} samples: a rolling fold would hold out {held}'
            continue
        judged.append((path.name, trace))
    return judged, not_judged


def _phones_here(data):
    """Return whether both GSDC phones of one drive are in ``data`` (their own sections)."""
    return all((data / p).exists() for p in PHONES)


def set_order(judged):
    """Return the sets' names in the page's order, given :func:`alone`'s recordings judged."""
    return [name for name, _ in judged] + [WALK_SET, PHONE_SET]


def sets(data):
    """
    Return ([(set name, how, [(label, Split)])] of the visible recordings, those not judged).

    The second is :func:`alone`'s {name: why}.
    """
    judged, not_judged = alone(data)
    out = [(name, 'rolling origin (3 folds)', rolling_splits(trace)) for name, trace in judged]
    walks = [_clean(p) for p in sorted(data.glob(WALKS))]
    if len(walks) > 1:
        out.append((WALK_SET, f'leave one walk out, nor train on the walks recorded '
                    f'with it ({len(walks)} folds)', recording_splits(walks)))
    if _phones_here(data):
        phones = [_clean(data / p) for p in PHONES]
        out.append((PHONE_SET, 'each phone trains, the other is held out',
                    [_cross(phones[0], phones[1]), _cross(phones[1], phones[0])]))
    return out, not_judged


def _table(summary):
    """
    Return a set's three tables: the score, the error's own measures, the consumers'.

    One table of every column would be wider than the page; each repeats the class.
    """
    groups = GROUPS + tuple(g for g in EXTRA_GROUPS
                            if any(g in s['groups'] for s in summary.values()))
    own = all('own' in s for s in summary.values())
    score = ['held-out NLL', 'best', '- population (<, >)']
    score += ['worst, own %', 'own at 0.90'] if own else []

    def cells(s):
        out = [f'{s["heldout_nll_per_sample"]:.3f}', f'{s["best_score_folds"]}',
               _against(s['nll_minus_population'])]
        if own:
            out += [f'{s["own"]["worst"]:.2f}, {s["own"]["percentile"]:.0f} %',
                    f'{s["own"]["own_meet_bar"]:.0f} %']
        return out

    def shares(s, names):
        return [f'{s["groups"][g]:.2f}' if g in s['groups'] else '-' for g in names]

    error = [g for g in groups if g in ERROR_GROUPS]
    consumers = [g for g in groups if g not in ERROR_GROUPS]
    tables = [_markdown(['class'] + score,
                        [[LABELS.get(c, c)] + cells(s) for c, s in summary.items()])]
    for names in (error, consumers):
        tables.append(_markdown(['class'] + names, [[LABELS.get(c, c)] + shares(s, names)
                                                    for c, s in summary.items()]))
    return '\n\n'.join(tables)


def _markdown(head, rows):
    """Return a Markdown table of a header and rows of cells."""
    lines = ['| ' + ' | '.join(head) + ' |', '|' + '---|' * len(head)]
    return '\n'.join(lines + ['| ' + ' | '.join(r) + ' |' for r in rows])


def _against(d):
    """Return a cell: the NLL minus the population's, and the folds beyond its interval."""
    return f'{d["mean"]:+.3f} ({d["lower_folds"]}, {d["higher_folds"]})'


def _score_sentence(summary, folds, cls='population'):
    """Return a sentence: the classes whose NLL is below the population's beyond noise."""
    lower = [f'{LABELS.get(c, c)} on {s["nll_minus_population"]["lower_folds"]}'
             for c, s in summary.items() if c != cls and s['nll_minus_population']['lower_folds']]
    if not lower:
        return ' ' + _words('score-none', folds=len(folds))
    return ' ' + _words('score-lower', lower='; '.join(lower), folds=len(folds))


def _evidence(folds):
    """Return lines on the population fits: block means against the process within."""
    lines = []
    for f in folds:
        ev = f['classes']['population']['fit']
        sec = f['classes']['population']['section']
        if not ev.get('fitted'):
            lines.append(_words('fold-no-fit', fold=f['fold'], reason=ev['reason']))
            continue
        tau = sec.get('bias_time_constant_s')
        lines.append(_words(
            'fold-fit', fold=f['fold'], blocks=ev['blocks'],
            spread_north=ev['block_mean_sd_m'][0], spread_east=ev['block_mean_sd_m'][1],
            within_north=ev['within_mean_sd_m'][0], within_east=ev['within_mean_sd_m'][1],
            bias_north=sec['bias_sd_m'][0], bias_east=sec['bias_sd_m'][1],
            wander=_words('wander-constant') if tau is None else _tau_words(tau, ev),
            scale=sec['scale_sd_log'], held=_held_words(f)))
    return lines


def _tau_words(tau, ev):
    """Return the time constant as the fit knows it: a value, or the bound it is."""
    tc = ev.get('bias_time_constant') or {}
    return _words('wander-bound' if tc.get('kind') == 'upper bound' else 'wander-value',
                  seconds=tau)


def _held_words(fold):
    """Return how the Gaussian-within population split its bias in two, or ''."""
    sec = fold['classes'].get('population_ar', {}).get('section') or {}
    if 'run_bias_sd_m' not in sec:
        return ''
    held, wander = sec['run_bias_sd_m'], sec['bias_sd_m']
    return ' ' + _words('held', held_north=held[0], held_east=held[1], wander_north=wander[0],
                        wander_east=wander[1], seconds=sec['bias_time_constant_s'])


def _drift_rows(folds):
    """Return table rows: each fold's held-out SD and lag-1 ACF against its training part's."""
    rows = []
    for f in folds:
        tr = f['train_measures']
        te = f['classes']['population']['measures']
        cells = []
        for key in ('scale:sd_north', 'scale:sd_east', 'persistence:acf1_north',
                    'persistence:acf1_east', 'bias:mean_north', 'bias:mean_east'):
            cells.append(f'{tr[key]:.2f} / {te[key]["measured"]:.2f}')
        rows.append(f'| {f["fold"]} | ' + ' | '.join(cells) + ' |')
    return rows


def _consumer_rows(folds, classes=('ar1', 'extended', 'population')):
    """Return table rows: the measured gate rate and each class's simulated range."""
    rows = []
    for f in folds:
        m = f['classes']['population']['measures']['filter:filter_gate_rate']['measured']
        cells = []
        for c in classes:
            r = f['classes'][c]['measures']['filter:filter_gate_rate']
            cells.append(f'{100 * r["sim_lo"]:.1f}-{100 * r["sim_hi"]:.1f}')
        rows.append(f'| {f["fold"]} | {100 * m:.1f} | ' + ' | '.join(cells) + ' |')
    return rows


def _filter_rows(folds, cls='population'):
    """Return the filter-parts table of the folds where the class's filter misses, or []."""
    rows = []
    for f in folds:
        c = f['classes'][cls]
        parts = c.get('filter_parts')
        if parts is None or c['groups'].get('filter', 1.0) >= 1.0:
            continue
        cells = [c['measures']['filter:filter_rms_m']] + [parts[k] for k in FILTER_PARTS]
        rows.append(f'| {f["fold"]} | ' + ' | '.join(
            f'{r["measured"]:.3g} ({r["percentile"]:.0f})' for r in cells) + ' |')
    if not rows:
        return []
    return ['\n' + TEMPLATE.snippet('filter-head') + '\n',
            '| fold | filter RMS m | mean size m | SD m | filter RMS per SD '
            '(the error less its mean) |\n|---|---|---|---|---|'] + rows


def _spread_cell(row):
    """Return a cell: a measured figure, its simulated 95 % range, **out** where outside."""
    return (f'{row["measured"]:.2f} ({row["sim_lo"]:.2f} to {row["sim_hi"]:.2f})'
            + ('' if inside(row) else ' **out**'))


def _spread_rows(folds, cls='population'):
    """Return the table of the training blocks' lag-1 ACF against the class's own, or []."""
    rows = []
    for f in folds:
        sp = f['classes'][cls].get('persistence_spread')
        if sp is None:
            continue
        rows.append(f'| {f["fold"]} | {sp["windows"]} | ' + ' | '.join(
            _spread_cell(sp[f'{k}_{ax}']) for k in ('acf1_sd', 'lowest_acf1')
            for ax in ('north', 'east')) + ' |')
    if not rows:
        return []
    return ['\n' + TEMPLATE.snippet('spread-head') + '\n',
            '| fold | blocks | ACF(1) SD N | ACF(1) SD E | lowest ACF(1) N | '
            'lowest ACF(1) E |\n|---|---|---|---|---|---|'] + rows


def _precedent_counts(folds):
    """Return (error measures outside the population's range, those without precedent)."""
    found = [precedent(f) for f in folds]
    return sum(len(m) for m, _ in found), sum(len(n) for _, n in found)


def _precedent_rows(folds):
    """Return table rows: each fold's misses of the population (``fold_summary.precedent``)."""
    rows = []
    for f in folds:
        miss, new = precedent(f)
        rows.append(f'| {f["fold"]} | {f.get("train_windows", {}).get("windows", 0)} | '
                    f'{", ".join(miss) or "none"} | {", ".join(new) or "none"} |')
    return rows


def _ratio_range(folds, key):
    """Return (min, max) over folds and axes of held-out / training ``key`` (an axis pair)."""
    r = [f['classes']['population']['measures'][f'{key}_{ax}']['measured'] /
         f['train_measures'][f'{key}_{ax}'] for f in folds for ax in ('north', 'east')]
    return min(r), max(r)


def _velocity_precedent(folds):
    """Return a sentence on the speed and course measures outside their ranges, or ''."""
    groups = [f['velocity'] for f in folds if f.get('velocity')]
    found = [velocity_precedent(g) for g in groups]
    miss = sum(len(m) for m, _, _ in found)
    if not miss:
        return ''
    new = sum(len(n) for _, n, _ in found)
    unmeasured = sum(len(u) for _, _, u in found)
    said = ' ' + _words('velocity-unmeasured', count=unmeasured) if unmeasured else ''
    return _words('velocity-precedent', misses=miss, new=new, unmeasured=said) + ' '


def _causes(parts):
    """Return bullets (a)-(e) with the figures of this run."""
    out = []
    for name, how, folds, summary in parts:
        fitted = [f['classes']['population']['fit'] for f in folds
                  if f['classes']['population']['fit'].get('fitted')]
        wander = [m / w for ev in fitted for m, w in zip(ev['block_mean_sd_m'],
                                                         ev['within_mean_sd_m'])]
        lo, hi = _ratio_range(folds, 'scale:sd')
        acf = [(f['train_measures'][f'persistence:acf1_{ax}'],
                f['classes']['population']['measures'][f'persistence:acf1_{ax}']['measured'])
               for f in folds for ax in ('north', 'east')]
        gate = [(f['classes']['ar1']['measures']['filter:filter_gate_rate'])
                for f in folds]
        above = sum(g['measured'] > g['sim_hi'] for g in gate)
        ext = summary['extended']
        best = max(summary, key=lambda c: min(summary[c]['groups'].values()))
        miss, new = _precedent_counts(folds)
        above_spread, judged = spread_above(folds)
        spread = _words('cause-spread', above=len(above_spread), judged=judged) + ' ' \
            if judged else ''
        said = _words('cause-precedent', misses=miss, new=new) + ' ' if miss else ''
        said += _velocity_precedent(folds)
        out.append(_words(
            'cause', name=name, how=how,
            wander=_words('cause-wander', low=min(wander), high=max(wander)) if wander
            else _words('cause-no-blocks'),
            sd_low=lo, sd_high=hi, acf_train_low=min(a for a, _ in acf),
            acf_train_high=max(a for a, _ in acf), acf_held_low=min(b for _, b in acf),
            acf_held_high=max(b for _, b in acf), spread=spread, precedent=said,
            gate_above=above, folds=len(folds), extended_best=ext['best_score_folds'],
            extended_worst=ext['worst_group']['inside_95'],
            extended_worst_group=ext['worst_group']['group'], best_class=LABELS.get(best, best),
            best_worst=min(summary[best]['groups'].values()),
            score=_score_sentence(summary, folds), own=_own_sentence(summary)))
    return out


def _beaten_lines(parts):
    """Return the section on the folds where a class scores better than the population."""
    out = []
    for name, how, folds, _ in parts:
        for f in folds:
            wb = f['classes']['population'].get('where_beaten')
            if not wb:
                continue
            who = ', '.join(LABELS.get(c, c) for c in wb['winners'])
            far, near = wb['far'], wb['near']
            out.append(_words(
                'beaten-fold', name=name, fold=f['fold'], winners=who,
                block_samples=wb['block_samples'], far_sd=wb['far_sd'],
                bias_north=wb['bias_sd_m'][0], bias_east=wb['bias_sd_m'][1],
                far_samples=far['samples'], near_samples=near['samples'],
                far='; '.join(f'{LABELS.get(c, c)} {gain_text(far[c])}'
                              for c in wb['winners'] if c in far) or 'none',
                near='; '.join(f'{LABELS.get(c, c)} {gain_text(near[c])}'
                               for c in wb['winners'] if c in near) or 'none'))
            pacf = wb.get('pacf') or {}
            if pacf.get('train') and pacf.get('held_out'):
                tr, te = pacf['train'], pacf['held_out']
                lags = len(tr['north'])
                out.append('\n' + _words('pacf-head', lags=lags) + '\n')
                out.append('| part, axis | bound | ' +
                           ' | '.join(str(k) for k in range(1, lags + 1)) + ' |\n|' +
                           '---|' * (lags + 2))
                for part, p in (('training', tr), ('held out', te)):
                    for axis in ('north', 'east'):
                        cells = [f'**{v:.2f}**' if abs(v) > p['bound'] else f'{v:.2f}'
                                 for v in p[axis][:lags]]
                        out.append(f'| {part}, {axis} | {p["bound"]:.3f} | ' +
                                   ' | '.join(cells) + ' |')
                out.append('\n' + _words('pacf-only', lags='; '.join(
                    f'{axis} ' + (', '.join(map(str, v)) or 'none')
                    for axis, v in pacf['only_in_training'].items())) + '\n')
            out.extend(_orders_lines(wb.get('orders')))
            out.append(_beaten_reading(wb, f['classes']['population']['fit']))
    return [TEMPLATE.snippet('beaten-head') + '\n'] + out if out else []


def _orders_lines(orders):
    """Return the sentence on the AR orders each part's own blocks choose, or none."""
    if not orders or not orders.get('train'):
        return []

    def part(name, o):
        if o is None:
            return _words('orders-few', part=name)
        gains = ' / '.join(f'{o[a]["gain_per_sample"]:.2f}' for a in ('north', 'east'))
        return _words('orders-part', part=name, blocks=o['blocks'], north=o['north']['order'],
                      east=o['east']['order'], gains=gains)
    return [_words('orders', train=part('training part', orders['train']),
                   held=part('held-out part', orders.get('held_out'))) + '\n']


def _orders_reading(orders, within):
    """
    Return what :func:`_orders_lines`' figures say of the lags, or ''.

    ``within``: the population fit's AR order within blocks per axis, or None.
    """
    train, held = (orders or {}).get('train'), (orders or {}).get('held_out')
    if not train:
        return ''
    axes = ('north', 'east')
    if held and all(train[a]['order'] > held[a]['order']
                    and train[a]['gain_per_sample'] >= ORDER_GAIN for a in axes):
        return _words('reading-more-lags')
    more = [a for a in axes if within and within[a] > train[a]['order']]
    if more:
        return _words('reading-lags-beyond', axes=', '.join(
            f'{a} {within[a]} against {train[a]["order"]}' for a in more))
    return ''


def _beaten_reading(wb, fit):
    """Return what a fold's :func:`_beaten_lines` figures say, as computed from them."""
    def resolved(part):
        return [LABELS.get(c, c) for c in wb['winners']
                if c in wb[part] and wb[part][c]['ci95'][1] < 0.0]
    near, far = resolved('near'), resolved('far')
    out = []
    if near:
        out.append(_words('reading-near', classes=', '.join(near), far_sd=wb['far_sd']))
    elif far:
        out.append(_words('reading-far', classes=', '.join(far), far_sd=wb['far_sd']))
    only = (wb.get('pacf') or {}).get('only_in_training')
    if only and all(only.values()):
        order = fit.get('within_order')
        out.append(_words('reading-pacf', order=' ' + _words(
            'reading-pacf-order', north=order['north'], east=order['east']) if order else ''))
    said = _orders_reading(wb.get('orders'), fit.get('within_order'))
    if said:
        out.append(said)
    return ('Reading: ' + ' '.join(out) + '\n') if out else ''


def _own_sentence(summary, cls='population'):
    """Return a sentence: the population's worst group read against its own traces'."""
    own = summary.get(cls, {}).get('own')
    if own is None:
        return ''
    others = [LABELS.get(c, c) for c, s in summary.items()
              if c != cls and 'own' in s and s['own']['percentile'] >= 5.0]
    return ' ' + _words('own', worst=own['worst'], percentile=own['percentile'],
                        bar=own['own_meet_bar'], others='; '.join(others) or 'none')


def _explanation(parts, data):
    """Return the section on what the folds show about why a profile fails to transfer."""
    out = [TEMPLATE.snippet('causes-head') + '\n'] + _causes(parts) + [''] + _beaten_lines(parts)
    if _phones_here(data):
        out += calm_section([(name, _clean(data / name)) for name in PHONES])
    out += ['', TEMPLATE.snippet('explain-head') + '\n']
    for name, how, folds, _ in parts:
        out.append(f'### {name}: {how}\n')
        out.append('| fold | SD N | SD E | ACF(1) N | ACF(1) E | mean N | mean E |\n'
                   '|---|---|---|---|---|---|---|')
        out += _drift_rows(folds)
        out.append('\n' + TEMPLATE.snippet('gate-head') + '\n')
        out.append('| fold | measured | AR(1) | extended | population |\n|---|---|---|---|---|')
        out += _consumer_rows(folds)
        out += _filter_rows(folds)
        out += _spread_rows(folds)
        out.append('\n' + TEMPLATE.snippet('precedent-head') + '\n')
        out.append('| fold | training windows | outside the population\'s range | '
                   'without precedent |\n|---|---|---|---|')
        out += _precedent_rows(folds)
        out.append('')
    return out


def main(argv=None):
    """Run every set; write the page and the JSON."""
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    ap.add_argument('--data', type=Path, required=True)
    ap.add_argument('--out', type=Path, default=Path('.'))
    ap.add_argument('--sims', type=int, default=100)
    ap.add_argument('--smoother', type=int, default=SMOOTHER_SIMS,
                    help='simulated traces of each of %s fed to GTSAM\'s iSAM2 too (0: '
                         'none)' % ', '.join(SMOOTHER_CLASSES))
    ap.add_argument('--from-json', action='store_true',
                    help='write the page from the JSON of the last run (no fitting)')
    args = ap.parse_args(argv)
    started = time.time()
    json_dir = args.out / 'docs' / 'generalisation'
    json_dir.mkdir(parents=True, exist_ok=True)
    rows_json = json_dir / TRANSFER_JSON
    page_json = json_dir / PAGE_JSON
    if args.from_json:
        docs = [json.loads(p.read_text()) for p in json_dir.glob('*.json')
                if p not in (rows_json, page_json)]
        if page_json.exists():          # the sets as the run that fitted them found them
            kept = json.loads(page_json.read_text())
            order, not_judged = kept['order'], kept['not_judged']
        else:
            judged, not_judged = alone(args.data)
            order = set_order(judged)
        docs.sort(key=lambda d: order.index(d['set']))
        rows = json.loads(rows_json.read_text()) if rows_json.exists() else []
        _write_page(args, [(d['set'], d['how'], d['folds'], d['summary']) for d in docs],
                    docs[0].get('seconds', 0.0), docs[0].get('date'), rows, not_judged)
        return
    parts = []
    found, not_judged = sets(args.data)
    for name, how, splits in found:
        folds = judge_folds(splits, args.sims, seed=0, smoother_sims=args.smoother,
                            smoother_classes=SMOOTHER_CLASSES)
        summary = summarise(folds)
        stem = name.replace('.csv', '').replace(' ', '-').lower()
        parts.append((name, how, folds, summary, stem))
        print(f'{name}: {len(folds)} folds done ({time.time() - started:.0f} s)', flush=True)
    rows = transfer(args.data, PHONES, json_dir, args.out / 'docs' / 'close-the-loop') \
        if _phones_here(args.data) else []
    rows_json.write_text(json.dumps(rows, indent=1))
    page_json.write_text(json.dumps({'order': [p[0] for p in parts],
                                     'not_judged': not_judged}, indent=1) + '\n')
    seconds, date = time.time() - started, dt.date.today().isoformat()
    for name, how, folds, summary, stem in parts:
        for f in folds:             # each simulated trace's shares: summarised, not kept
            for c in f['classes'].values():
                c.pop('own_groups', None)
        (json_dir / f'{stem}.json').write_text(json.dumps(
            {'set': name, 'how': how, 'folds': folds, 'summary': summary,
             'seconds': seconds, 'date': date}, indent=1, default=float))
    _write_page(args, [p[:4] for p in parts], seconds, date, rows, not_judged)


def _velocity_rows(folds):
    """Return the speed and course table of a set's folds, or [] where none has the group."""
    if not any(f.get('velocity') for f in folds):
        return []
    rows = ['Speed and course (the velocity section fitted on the training rows, the same '
            'for every class; measured on the held-out rows, against the simulated 95 % '
            'range; the section\'s SD at 3, 10 and 27 m/s from its `sigma_by_speed`, its '
            'lags of the speed and the course; and the range of the measure over the '
            'training rows\' stretches as long as the held-out rows, stepped by half of '
            'that: a held-out value outside it, **new**, has no precedent in training, '
            '"-" where no stretch had rows enough in the band). A miss with a precedent '
            'says that the training rows\' own stretches spread that far while the section, '
            'one stationary process, simulates a narrower spread; a miss without one, that '
            'nothing the section was fitted on was like the held-out rows:\n',
            '| fold | section: SD at 3 / 10 / 27 m/s, phi, lags (s) | measure | held out '
            '| simulated 95 % | training stretches |', '|---|---|---|---|---|---|']
    for f in folds:
        g = f.get('velocity')
        if not g:
            continue
        sec = g['section']
        vel = velocity_from_dict(sec)
        sds = ' / '.join(f'{v:.2f}' for v in vel.sd_at(SPEEDS))
        lags = ' / '.join(f'{v:.1f}' for v in vel.lags)
        rng = (g.get('train_windows') or {}).get('range', {})
        for name, r in g['measures'].items():
            out = '' if inside(r) else ' **out**'
            seen = '-' if name not in rng else f'{rng[name][0]:.3f} to {rng[name][1]:.3f}' + (
                '' if rng[name][0] <= r['measured'] <= rng[name][1] else ' **new**')
            rows.append(f'| {f["fold"]} | {sds}, {sec["phi"]:.2f}, '
                        f'{lags} | {name} | {r["measured"]:.3f}{out} | '
                        f'{r["sim_lo"]:.3f} to {r["sim_hi"]:.3f} | {seen} |')
    return rows + ['']


def _write_page(args, parts, seconds, date=None, rows=(), not_judged=None):
    machine = f'{platform.machine()}, {platform.python_implementation()} ' \
              f'{platform.python_version()}'
    text = [TEMPLATE.page(date=date or dt.date.today().isoformat(), machine=machine,
                          minutes=seconds / 60.0, sims=args.sims)]
    for name, how, folds, summary in parts:
        text.append(f'## {name}: {how}\n')
        text.append('Folds: ' + '; '.join(
            f'{f["fold"]} ({f["train_samples"]} train, {f["test_samples"]} held out)'
            for f in folds) + '.\n')
        text.append(_table(summary) + '\n')
        text.append('Population fits:\n\n' + '\n'.join(_evidence(folds)) + '\n')
        text += _velocity_rows(folds)
    for name, why in (not_judged or {}).items():
        text.append(f'Not judged: {name} ({why}).\n')
    text += transfer_lines(rows)
    text += _explanation(parts, args.data)
    path = args.out / 'docs' / 'generalisation.md'
    path.write_text('\n'.join(text))
    print(f'wrote {path}')


if __name__ == '__main__':
    main()
