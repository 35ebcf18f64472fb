"""
Build the fitted preset ``phone-suburban-drive`` and write ``docs/presets.md``.

Run ``make presets`` (or ``python tools/presets.py --data data --out .``).
The preset is ``gps_error calibrate --population --within ar`` of the GSDC Pixel 4
drive (Apache-2.0), written to ``config/profiles/``. It is then checked on
data the fit did not see, with ``gps_error validate``: the other phone of the
same drive (Pixel 4 XL, modified), and the last 30 % of the Pixel 4 drive
under a profile fitted on its first 70 %. The page's prose is the template
``tools/presets_page.md``; its figures come from the validation JSON written
under ``docs/presets/``.
"""

import argparse
import json
from pathlib import Path
import subprocess
import sys
import tempfile

import yaml

from gps_error_ros.fit.validation import slice_trace
from gps_error_ros.model.profiles import builtin_dir
from gps_error_ros.traces.trace_io import read_trace_csv, write_trace_csv

NAME = 'phone-suburban-drive'
DESCRIPTION = ('a phone (Google Pixel 4, its own location output) in a car on suburban '
               'roads and highway, Mountain View CA')
TRAIN = 'gsdc2020-mtv1-pixel4.csv'
OTHER_PHONE = 'gsdc2020-mtv1-pixel4xlmodded.csv'
TEMPLATE = Path(__file__).with_name('presets_page.md')
SIMS = '300'


def gps_error(*args, cwd=None):
    """Run ``gps_error ARGS`` in this interpreter (in folder ``cwd``); stop on failure."""
    cmd = [sys.executable, '-m', 'gps_error_ros.cli', *map(str, args)]
    print('$ gps_error ' + ' '.join(map(str, args)), flush=True)
    subprocess.run(cmd, check=True, cwd=cwd)


def build(data, root):
    """Fit the preset into config/profiles/; return its path."""
    path = root / 'config' / 'profiles' / f'{NAME}.yaml'
    gps_error('calibrate', data / TRAIN, '--population', '--within', 'ar', '--name', NAME,
              '-o', path)
    raw = yaml.safe_load(path.read_text())
    raw['description'] = DESCRIPTION
    raw['source'] = (f'make presets: gps_error calibrate --population --within ar {TRAIN} '
                     f'(GSDC 2020, Google)')
    path.write_text('# Written by make presets (tools/presets.py); do not edit by hand.\n'
                    + yaml.safe_dump(raw, sort_keys=False, width=100))
    return path


def held_out(data, root, preset):
    """
    Validate on the other phone and on the drive's last 30 %; return the records.

    The preset's own order (the PACF's) and the paper's AR(3) fitted the same
    way side by side: {(check, label): validation JSON}.
    """
    out = (root / 'docs' / 'presets').resolve()
    out.mkdir(parents=True, exist_ok=True)
    data, preset = data.resolve(), preset.resolve()
    checks = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        trace = read_trace_csv(data / TRAIN)
        write_trace_csv(slice_trace(trace, 0.0, 0.7), tmp / 'first70.csv')
        write_trace_csv(slice_trace(trace, 0.7, 1.0), tmp / 'last30.csv')
        # the temporary files by their names alone (run in tmp): the JSON names them
        for label, order in (('pacf', ()), ('ar3', ('--order', '3'))):
            whole = 'ar3.yaml' if order else (
                NAME if preset == (builtin_dir() / f'{NAME}.yaml').resolve() else preset)
            if order:
                gps_error('calibrate', data / TRAIN, '--population', '--within', 'ar', *order,
                          '-o', whole,
                          cwd=tmp)
            first = f'first70-{label}.yaml'
            gps_error('calibrate', 'first70.csv', '--population', '--within', 'ar', *order,
                      '-o', first, cwd=tmp)
            for check, profile, target in (('other-phone', whole, data / OTHER_PHONE),
                                           ('last-30', first, 'last30.csv')):
                where = out / f'{check}-{label}'
                gps_error('validate', profile, target, '--out', where, '--sims', SIMS,
                          '--seed', '1', cwd=tmp)
                checks[check, label] = json.loads((where / 'validation.json').read_text())
    return checks


def _row(label, v):
    """Return a table row of one validation's figures."""
    n, e = v['north'], v['east']
    acc = v.get('reported_accuracy') or {}
    cov = acc.get('coverage', {})
    coverage = (f"{cov['measured']:.2f} ({cov['sim_lo']:.2f} to {cov['sim_hi']:.2f})"
                if cov else 'n/a')
    return (f"| {label} | {v['samples']} | {n['acf_lags_inside_envelope']:.0%} / "
            f"{e['acf_lags_inside_envelope']:.0%} | {n['quantiles_inside_envelope']:.0%} / "
            f"{e['quantiles_inside_envelope']:.0%} | {v['shares_joint_percentile']:.0f} | "
            f"{coverage} |")


def render(checks, preset):
    """Return docs/presets.md: the template with its figures."""
    raw = yaml.safe_load(preset.read_text())
    orders = raw['fit']['order_selection']
    names = {'other-phone': 'Pixel 4 XL (modified), same drive: another phone',
             'last-30': 'Pixel 4, last 30 % (fitted on the first 70 %)'}
    rows = [_row(f'{names[check]}; {"the preset" if label == "pacf" else "AR(3)"}', v)
            for (check, label), v in checks.items()]
    return TEMPLATE.read_text().replace('{{HELD_OUT_ROWS}}', '\n'.join(rows)).replace(
        '{{ORDERS}}', f"{orders['north']['order']} north, {orders['east']['order']} east")


def main(argv=None):
    """Build the preset and its page."""
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--data', default='data', help='folder of the measured traces')
    ap.add_argument('--out', default='.', help='the repository root to write into')
    args = ap.parse_args(argv)
    data, root = Path(args.data), Path(args.out)
    preset = build(data, root)
    checks = held_out(data, root, preset)
    (root / 'docs' / 'presets.md').write_text(render(checks, preset))
    print(f'wrote {preset}, docs/presets.md and docs/presets/')
    return 0


if __name__ == '__main__':
    sys.exit(main())
