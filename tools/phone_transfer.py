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


TABLE_HEAD = """## Each phone's profile on the other phone

The two GSDC phones rode one drive: each phone's profiles, validated on the
other phone's recording (`gps_error validate PROFILE OTHER.csv --sims {sims}`):
another receiver, the nearest to another day that the visible data hold. The
shares of autocorrelation lags 1-60 and of the 99 quantiles inside the
simulated 95 % envelopes, per axis, and the four shares judged together
(their smallest percentile against the simulated traces' own: below 5 the
recording is unlike the profile's traces at the 5 % level;
[checking](checking.md)). The extended profile describes the stretch it was
fitted on; the population profile (`gps_error diagnose X.csv --profile-out
X.population.yaml --population`, in `docs/generalisation/`) draws each
agent's bias and scale from the spread of the drive's 300-s blocks: it is
the profile meant for other drives, days and phones.

| profile | validated on | ACF N | quantiles N | ACF E | quantiles E | joint percentile |
|---|---|---|---|---|---|---|"""


def transfer_lines(rows):
    """Return the section's markdown lines from :func:`transfer`'s rows."""
    if not rows:
        return []
    out = [TABLE_HEAD.format(sims=rows[0]['sims'])]
    for r in rows:
        out.append(f'| {r["profile"]} | {r["validated_on"]} | ' +
                   ' | '.join(f'{100 * r[ax][m]:.0f} %' for ax in ('north', 'east')
                              for m in ('acf', 'quantiles')) +
                   f' | {r["joint_percentile"]:.0f} |')
    return out + ['']
