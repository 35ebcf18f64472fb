"""
Regenerate ``docs/calibration.md``: calibrate and validate every measured trace.

Run ``make calibration-doc`` (or ``python tools/calibration_doc.py``).
For each trace CSV in the data directory: fit with the PACF-chosen order and
with the paper's fixed AR(3); validate both in-sample (as the paper did) and,
where the trace is long enough, fit on the first 70 % of its duration and
validate on the last 30 %. Writes figures, profiles and JSON under
``docs/calibration/`` and the document itself, its words from
``tools/templates/calibration.md`` (``--render``: from the JSON already there).
"""

import argparse
import json
from pathlib import Path

from data_sources import CREDITS
from page_template import Template

from gps_error_ros.fit.holdout import split_trace
from gps_error_ros.judge.zoned_compare import compare_zones
from gps_error_ros.fit.calibration import calibrate, CalibrationError
from gps_error_ros.fit.zone_calibration import calibrate_zones, MIN_ZONE_SAMPLES
from gps_error_ros.fit.validation import slice_trace, validate
from gps_error_ros.model.profiles import profile_from_dict, write_profile
from gps_error_ros.model.zones import load_zone_map
from gps_error_ros.reports.validation_figure import validation_figure
from gps_error_ros.traces.trace_io import read_trace_csv

MIN_HOLDOUT_SAMPLES = 600
SIMS = 300
#: The page's words (tools/templates/calibration.md).
TEMPLATE = Template('calibration')
#: Zone maps drawn from a drive's own environment (docs/calibration/), by trace prefix.
ZONE_MAPS = {'gsdc2020-mtv1-': 'gsdc2020-mtv1-zones.geojson'}
#: Recordings calibrated together elsewhere (docs/walks.md, make walks-profile), by prefix.
ELSEWHERE = ('snapper-walk-',)


def _fits(trace):
    out = {}
    for label, order in (('pacf', None), ('ar3', 3)):
        try:
            out[label] = calibrate(trace, order=order)
        except CalibrationError as exc:
            out[label] = exc
    return out


def _val(result, trace, name, fig, title):
    model = profile_from_dict(result.profile_dict(name)).model()
    res = validate(model, trace, sims=SIMS)
    if fig is not None:
        validation_figure(res, fig, title)
    s = res.to_dict()
    return {ax: {k: s[ax][k] for k in ('acf_lags_inside_envelope',
                                       'quantiles_inside_envelope',
                                       'acf_offset_rms_lags_1_10')}
            for ax in ('north', 'east')} | {'samples': res.samples}


def run(data_dir, out_dir):
    """Process every trace; return the per-trace records."""
    data_dir, out_dir = Path(data_dir), Path(out_dir)
    sub = out_dir / 'calibration'
    sub.mkdir(parents=True, exist_ok=True)
    records = []
    for csv_path in sorted(data_dir.glob('*.csv')):
        if csv_path.name.startswith(ELSEWHERE):
            continue
        trace = read_trace_csv(csv_path)
        stem = csv_path.stem
        rec = {'trace': csv_path.name, 'rows': len(trace),
               'resolution_m': _resolution_m(trace)}
        fits = _fits(trace)
        for label, res in fits.items():
            if isinstance(res, Exception):
                rec[label] = {'refused': str(res)}
                continue
            prof = res.profile_dict(f'{stem}-{label}',
                                    description=CREDITS.get(csv_path.name, ('',))[0],
                                    source=f'gps_error calibrate {csv_path.name}')
            write_profile(sub / f'{stem}-{label}.yaml', prof)
            fig = sub / f'{stem}-{label}-insample.png' if label == 'pacf' else None
            rec[label] = {
                'profile': prof['axes'],
                'segments': len(res.grid.segments),
                'samples': res.grid.n,
                'evidence': prof['fit']['order_selection'],
                'insample': _val(res, trace, stem, fig,
                                 f'{csv_path.name}: PACF-order fit, validated '
                                 f'in-sample'),
            }
        if len(trace) >= MIN_HOLDOUT_SAMPLES:
            train, test = slice_trace(trace, 0.0, 0.7), slice_trace(trace, 0.7, 1.0)
            rec['holdout'] = {'train_samples': len(train), 'test_samples': len(test)}
            for label, res in _fits(train).items():
                if isinstance(res, Exception):
                    rec['holdout'][label] = {'refused': str(res)}
                    continue
                fig = sub / f'{stem}-{label}-holdout.png' if label == 'pacf' else None
                rec['holdout'][label] = _val(
                    res, test, stem, fig,
                    f'{csv_path.name}: fitted on the first 70 %, validated on '
                    f'the last 30 %')
                rec['holdout'][label]['order'] = {
                    'north': res.north.params.order, 'east': res.east.params.order}
        zones = _zones(trace, sub, stem)
        if zones:
            rec['zones'] = zones
        (sub / f'{stem}.json').write_text(json.dumps(rec, indent=1) + '\n')
        records.append(rec)
    (out_dir / 'calibration.md').write_text(render(records))
    return records


def _zones(trace, sub, stem):
    """Return per-zone calibration and one-vs-per-zone on the held-out part, or None."""
    name = next((m for p, m in ZONE_MAPS.items() if stem.startswith(p)), None)
    if name is None:
        return None
    zmap = load_zone_map(sub / name)
    _, fits = calibrate_zones(trace, zmap)
    whole = {f.name: {'samples': f.samples, 'reason': f.reason, 'sd': None if f.fits is None
                      else [float(v) for v in _sd(f.fits)]} for f in fits}
    split = split_trace(trace)
    origin = (float(trace.truth_lat[0]), float(trace.truth_lon[0]))
    held = compare_zones(split, zmap, origin, sims=100, seed=0)
    for c in held['classes'].values():
        c['fidelity'].pop('measures')
    return {'map': name, 'whole_trace': whole, 'heldout': held}


def _sd(fits):
    from gps_error_ros.model.ar_model import ARErrorModel
    return ARErrorModel(fits[0].params, fits[1].params).stationary_sd


def render_zones(records):
    """Return the per-zone calibration section of the document."""
    recs = [r for r in records if 'zones' in r]
    if not recs:
        return ''
    lines = [TEMPLATE.snippet('zones-head', map=recs[0]['zones']['map'],
                              min_zone=MIN_ZONE_SAMPLES), '']
    for r in recs:
        z = r['zones']
        lines += [f'### {r["trace"]}', '', '| zone | samples | stationary SD north / east '
                  '(whole drive) |', '|---|---|---|']
        for name, w in z['whole_trace'].items():
            sd = (f'{w["sd"][0]:.2f} / {w["sd"][1]:.2f} m' if w['sd'] else
                  f'fallback: {w["reason"]}')
            lines.append(f'| {name} | {w["samples"]} | {sd} |')
        h = z['heldout']
        imp = h['nll_improvement']
        lines += ['', '| held out | NLL per sample | inside_95 |', '|---|---|---|']
        for name, c in h['classes'].items():
            lines.append(f'| {name.replace("_", " ")} | {c["heldout_nll_per_sample"]:.4f} | '
                         f'{c["fidelity"]["inside_95"]:.2f} |')
        lines += ['', TEMPLATE.snippet('zones-gain', gain=imp['per_sample'],
                                       low=imp['ci95'][0], high=imp['ci95'][1]), '']
        for name, e in h['zones'].items():
            if 'heldout_samples' in e:
                lines.append(TEMPLATE.snippet(
                    'zone-line', zone=name,
                    whose='its own profile' if e.get('fitted') else 'the one profile',
                    samples=e['heldout_samples'], one=e['heldout_nll_one_profile'],
                    per_zone=e['heldout_nll_per_zone']))
        lines.append('')
    spans = [r['zones']['heldout']['nll_improvement']['ci95'] for r in recs]
    zero = all(lo <= 0.0 <= hi for lo, hi in spans)
    fid = [abs(r['zones']['heldout']['classes']['per_zone']['fidelity']['inside_95']
               - r['zones']['heldout']['classes']['one_profile']['fidelity']['inside_95'])
           for r in recs]
    train = {n: e['train_samples'] for r in recs
             for n, e in r['zones']['heldout']['zones'].items() if 'train_samples' in e}
    lines += [TEMPLATE.snippet('zones-zero' if zero else 'zones-nonzero') + ' ' +
              TEMPLATE.snippet('zones-tail', fidelity=max(fid),
                               train=', '.join(f'{n} {v}' for n, v in train.items())), '']
    return '\n'.join(lines)


def _resolution_m(trace):
    """Return the smallest non-zero step of the fixes' coordinates, in m."""
    import numpy as np
    out = {}
    for ax, values, scale in (
            ('north', trace.lat, 111_320.0),
            ('east', trace.lon, 111_320.0 * np.cos(np.radians(trace.lat.mean())))):
        steps = np.abs(np.diff(np.unique(values)))
        out[ax] = float(round(steps.min() * scale, 4)) if steps.size else None
    return out


def _pct(x):
    return f'{100 * x:.0f} %'


def render(records):
    """Return the markdown document: the template with every trace's section."""
    sections = []
    for rec in records:
        sections += _trace_lines(rec)
    return TEMPLATE.page(sims=SIMS, holdout_samples=MIN_HOLDOUT_SAMPLES,
                         traces='\n'.join(sections), zones=render_zones(records))


def _trace_lines(rec):
    """Return one trace's section."""
    name = rec['trace']
    what, credit = CREDITS.get(name, ('', 'see data/README.md'))
    stem = Path(name).stem
    lines = [TEMPLATE.snippet('trace', name=name, what=what, rows=rec['rows'], credit=credit),
             '']
    pacf = rec.get('pacf', {})
    if 'refused' in pacf:
        return lines + [TEMPLATE.snippet('refused', why=pacf['refused']), '']
    ev = pacf['evidence']
    lines += ['| axis | PACF order | BIC order | delta | phi | sigma_w (m) |',
              '|---|---|---|---|---|---|']
    for ax in ('north', 'east'):
        p = pacf['profile'][ax]
        phi = ', '.join(f'{v:.3f}' for v in p['phi'])
        lines.append(f'| {ax} | {ev[ax]["pacf_order"]} | {ev[ax]["bic_order"]} '
                     f'| {p["delta"]:.4f} | {phi} | {p["sigma_w"]:.3f} |')
    lines += ['', TEMPLATE.snippet('samples', samples=pacf['samples'],
                                   segments=pacf['segments']), '']
    res_m = rec['resolution_m']
    strongest = {ax: max(range(2, len(ev[ax]['pacf']) + 1),
                         key=lambda k: abs(ev[ax]['pacf'][k - 1]))
                 for ax in ('north', 'east')}
    lines += [TEMPLATE.snippet(
        'facts', step_north=res_m['north'], step_east=res_m['east'],
        lag_north=strongest['north'], pacf_north=ev['north']['pacf'][strongest['north'] - 1],
        lag_east=strongest['east'], pacf_east=ev['east']['pacf'][strongest['east'] - 1],
        bound=ev['north']['pacf_bound']), '']
    lines += _fit_table(pacf, rec.get('ar3', {}), ev)
    lines += ['', f'![in-sample validation](calibration/{stem}-pacf-insample.png)', '']
    return lines + _holdout_lines(rec.get('holdout'), stem)


def _fit_table(pacf, ar3, ev):
    """Return the table of both fits validated in-sample."""
    lines = ['| model | axis | sigma_w (m) | BIC | ACF lags inside (in-sample) '
             '| quantiles inside | ACF offset RMS 1-10 |', '|---|---|---|---|---|---|---|']
    for label, res in (('PACF order', pacf), ('AR(3)', ar3)):
        if 'refused' in res:
            lines.append(f'| {label} | | refused: {res["refused"]} | | | | |')
            continue
        for ax in ('north', 'east'):
            order = len(res['profile'][ax]['phi'])
            bic = ev[ax]['bic'][order - 1] if order <= len(ev[ax]['bic']) else ''
            v = res['insample'][ax]
            lines.append(
                f'| {label} (p={order}) | {ax} | {res["profile"][ax]["sigma_w"]:.3f}'
                f' | {bic} | {_pct(v["acf_lags_inside_envelope"])} | '
                f'{_pct(v["quantiles_inside_envelope"])} | '
                f'{v["acf_offset_rms_lags_1_10"]:.3f} |')
    return lines


def _holdout_lines(ho, stem):
    """Return the held-out validation's lines, or why there is none."""
    if not ho:
        return [TEMPLATE.snippet('too-short', holdout_samples=MIN_HOLDOUT_SAMPLES), '']
    lines = [TEMPLATE.snippet('held-out', train=ho['train_samples'], test=ho['test_samples']),
             '', '| model | axis | ACF lags inside | quantiles inside '
             '| ACF offset RMS 1-10 |', '|---|---|---|---|---|']
    for label, key in (('PACF order', 'pacf'), ('AR(3)', 'ar3')):
        res = ho.get(key, {})
        if 'refused' in res:
            lines.append(f'| {label} | | refused: {res["refused"]} | | |')
            continue
        for ax in ('north', 'east'):
            v = res[ax]
            lines.append(
                f'| {label} (p={res["order"][ax]}) | {ax} | '
                f'{_pct(v["acf_lags_inside_envelope"])} | '
                f'{_pct(v["quantiles_inside_envelope"])} | '
                f'{v["acf_offset_rms_lags_1_10"]:.3f} |')
    return lines + ['', f'![held-out validation](calibration/{stem}-pacf-holdout.png)', '']


def load(out_dir):
    """Return the records a run left in ``out_dir``/calibration (one JSON per trace)."""
    return [json.loads(p.read_text())
            for p in sorted((Path(out_dir) / 'calibration').glob('*.json'))]


#: The repository's measured recordings (data/README.md).
DATA = Path(__file__).resolve().parents[1] / 'data'


def main(argv=None):
    """Command-line entry point."""
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0].strip())
    p.add_argument('--data', default=str(DATA), help='trace CSV directory')
    p.add_argument('--out', default='docs', help='docs directory')
    p.add_argument('--render', action='store_true',
                   help='write the page from the template and the JSON already there')
    args = p.parse_args(argv)
    if args.render:
        (Path(args.out) / 'calibration.md').write_text(render(load(args.out)))
        print(f'wrote {Path(args.out) / "calibration.md"}')
        return 0
    for rec in run(args.data, args.out):
        print(f'{rec["trace"]}: done')
    print(f'wrote {Path(args.out) / "calibration.md"}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
