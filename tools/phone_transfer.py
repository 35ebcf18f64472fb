"""
Each GSDC phone's profiles validated on the other phone of the same drive.

A user who profiles a phone on one drive simulates other drives, days and
phones with it. The visible data hold one drive with two phones, so the other
phone is the nearest such test here. Two profiles of each phone, each made by
the command a user runs, are validated (``gps_error validate``) on the other
phone's recording:

* the extended profile of one stretch, as ``docs/close-the-loop/`` ships it
  (``gps_error diagnose X --profile-out P``);
* the population profile (``gps_error diagnose X --profile-out P
  --population``), written to ``docs/generalisation/<stem>.population.yaml``.

:func:`transfer` runs them; :func:`transfer_lines` renders the table.
"""

import json
from pathlib import Path
import tempfile

from page_template import Template

from gps_error_ros.cli import main as cli

#: The profiles of each phone: the extended one of a stretch, the population one.
KINDS = ('extended', 'population')


def _profile(kind, stem, close_loop_dir, out_dir):
    """Return the path of ``stem``'s profile of ``kind`` (the population one is written)."""
    if kind == 'extended':
        return close_loop_dir / f'{stem}.extended.yaml'
    return out_dir / f'{stem}.population.yaml'


def transfer(data, phones, out_dir, close_loop_dir, sims=200):
    """
    Validate each phone's profiles on every other phone; return the rows.

    ``phones``: the recordings' file names in ``data``. Writes each phone's
    population profile to ``out_dir`` first (``diagnose --population``,
    seed 0). Each row: ``{'profile', 'kind', 'validated_on', 'north',
    'east', 'joint_percentile'}``, ``north`` / ``east`` the shares of ACF
    lags 1-60 and of quantiles inside the simulated envelopes.
    """
    rows = []
    for name in phones:
        stem = Path(name).stem
        out = _profile('population', stem, close_loop_dir, out_dir)
        if cli(['diagnose', str(data / name), '--profile-out', str(out), '--population']):
            raise SystemExit(f'gps_error diagnose {name} --population failed')
        for other in phones:
            if other == name:
                continue
            for kind in KINDS:
                path = _profile(kind, stem, close_loop_dir, out_dir)
                with tempfile.TemporaryDirectory() as tmp:
                    if cli(['validate', str(path), str(data / other), '--out', tmp,
                            '--sims', str(sims)]):
                        raise SystemExit(f'gps_error validate {path} {other} failed')
                    s = json.loads((Path(tmp) / 'validation.json').read_text())
                rows.append({'profile': path.name, 'kind': kind, 'validated_on': other,
                             'sims': sims,
                             **{ax: {'acf': s[ax]['acf_lags_inside_envelope'],
                                     'quantiles': s[ax]['quantiles_inside_envelope']}
                                for ax in ('north', 'east')},
                             'joint_percentile': s['shares_joint_percentile']})
    return rows


#: The section's words are the generalisation page's (tools/templates/generalisation.md).
TEMPLATE = Template('generalisation')


def transfer_lines(rows):
    """Return the section's markdown lines from :func:`transfer`'s rows."""
    if not rows:
        return []
    out = [TEMPLATE.snippet('transfer-head', sims=rows[0]['sims'])]
    for r in rows:
        out.append(f'| {r["profile"]} | {r["validated_on"]} | ' +
                   ' | '.join(f'{100 * r[ax][m]:.0f} %' for ax in ('north', 'east')
                              for m in ('acf', 'quantiles')) +
                   f' | {r["joint_percentile"]:.0f} |')
    return out + ['']
