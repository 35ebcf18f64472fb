"""
Write docs/model.md: what the model is, and how good it is, with its figure.

The presets' typical errors are simulated (200 agents of 30 minutes each,
gross failures left out); the figure sets measured errors the fits did not
see beside the simulated ones: the Pixel 4 XL of the GSDC drive against
``phone-suburban-drive`` (fitted on the Pixel 4), and a SnapperGPS walk
left out against a population fitted on the walks of the other occasions.
The words are ``tools/templates/model.md``.

    python tools/model_page.py [--data data] [--out .]      # make model-page, about a minute
"""

import argparse
import datetime as dt
from pathlib import Path
import platform
import sys

import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from page_template import Template  # noqa: E402

import gps_error_ros as ge  # noqa: E402
from gps_error_ros.fit.gross_failures import find_gross_failures  # noqa: E402
from gps_error_ros.fit.population_fit import occasions  # noqa: E402
from gps_error_ros.model.geodesy import difference  # noqa: E402
from gps_error_ros.model.streams import agent_keys  # noqa: E402
from gps_error_ros.traces.trace_io import read_trace_csv  # noqa: E402

#: The built-in profiles that can be simulated, and what each was measured on.
PRESETS = {'DS1': "the paper: a Nexus 5 on foot, Manhattan's 9th Avenue",
           'DS2': "the paper: a Pixel on foot, 9th Avenue",
           'DS5': "the paper: a Pixel on foot, 7th Avenue",
           'DS7': "the paper: a Nexus 5 on foot, 7th Avenue",
           'phone-suburban-drive': 'a Pixel 4 in a car, Mountain View (GSDC 2020)',
           'snapshot-receiver-on-foot': 'a SnapperGPS receiver on 7 walks, Oxford'}
AGENTS, RUN_S, SIMS, LAGS = 200, 1800, 200, 60
#: Traces and seed of each held-out check, as the presets page's (``gps_error validate``).
VALIDATE_SIMS = 300
HELD_WALK = 'snapper-walk-w06.csv'
TEMPLATE = Template('model')


def typical(name, seed=1):
    """Return a preset's per-axis RMS, and its 2-D median and 95 % with their spread over runs."""
    profile = ge.load_profile(name)
    model = profile.model(about_truth=True, gross_failures=False)
    e = model.simulate(agent_keys(seed, [f'a{i}' for i in range(AGENTS)]), RUN_S)
    r = np.hypot(e[..., 0], e[..., 1])                     # (steps, agents)
    med, q95 = np.median(r, axis=0), np.quantile(r, 0.95, axis=0)
    rms = np.sqrt(np.mean(e ** 2, axis=(0, 1)))
    return dict(rms_n=rms[0], rms_e=rms[1], median=np.median(med),
                median_lo=np.quantile(med, 0.025), median_hi=np.quantile(med, 0.975),
                q95=np.median(q95), q95_lo=np.quantile(q95, 0.025),
                q95_hi=np.quantile(q95, 0.975))


def measured(trace):
    """Return a trace's (north, east) errors, m, its gross failures left out."""
    keep = ~find_gross_failures(trace).mask
    north, east = difference(trace.lat, trace.lon, trace.truth_lat, trace.truth_lon)
    return np.stack([north, east], axis=1)[keep]


def simulated(profile, steps, seed=0):
    """Return SIMS simulated traces (sims, steps, 2), each another agent, failures left out."""
    model = profile.model(about_truth=True, gross_failures=False)
    e = model.simulate(agent_keys(seed, [f'sim{i}' for i in range(SIMS)]), steps)
    return e.transpose(1, 0, 2)


def acf(x, lags=LAGS):
    """Return the autocorrelation of a series at lags 0..lags."""
    x = x - x.mean()
    d = float(x @ x)
    return np.array([1.0] + [float(x[:-k] @ x[k:]) / d for k in range(1, lags + 1)])


def case(profile, errors):
    """Return the figures of one held-out recording against its profile's traces."""
    sims = simulated(profile, len(errors))
    real_acf = acf(errors[:, 0])
    sim_acf = np.array([acf(s[:, 0]) for s in sims])
    lo, hi = np.quantile(sim_acf, [0.025, 0.975], axis=0)
    inside = float(np.mean((real_acf[1:] >= lo[1:]) & (real_acf[1:] <= hi[1:])))
    r = np.hypot(errors[:, 0], errors[:, 1])
    sim_r = np.hypot(sims[..., 0], sims[..., 1])
    qs = np.array([0.5, 0.68, 0.95])
    sim_q = np.quantile(sim_r, qs, axis=1)                 # (3, sims)
    return dict(errors=errors, sims=sims, real_acf=real_acf, acf_lo=lo, acf_hi=hi,
                acf_mid=np.median(sim_acf, axis=0), acf_inside=inside,
                q=np.quantile(r, qs), q_mid=np.median(sim_q, axis=1),
                q_lo=np.quantile(sim_q, 0.025, axis=1), q_hi=np.quantile(sim_q, 0.975, axis=1),
                q_pct=[float(np.mean(sim_q[k] <= np.quantile(r, qs[k])) * 100)
                       for k in range(len(qs))])


def draw(cases, path):
    """Write the figure: per case, errors over time, autocorrelation, error distribution."""
    fig, axes = plt.subplots(len(cases), 3, figsize=(13, 4.2 * len(cases)))
    for row, (title, c) in zip(axes, cases):
        n = min(len(c['errors']), 600)
        t = np.arange(n)
        row[0].plot(t, c['errors'][:n, 0], 'k', lw=1.2, label='measured (held out)')
        row[0].plot(t, c['sims'][0, :n, 0], color='tab:orange', lw=1.0, label='simulated')
        row[0].plot(t, c['sims'][1, :n, 0], color='tab:blue', lw=1.0, alpha=0.7,
                    label='another simulated agent')
        row[0].set(title=f'{title}: north error', xlabel='s', ylabel='m')
        row[0].legend(fontsize=8)
        lags = np.arange(LAGS + 1)
        row[1].fill_between(lags, c['acf_lo'], c['acf_hi'], color='tab:orange', alpha=0.3,
                            label=f'simulated 95 % ({SIMS} traces)')
        row[1].plot(lags, c['acf_mid'], color='tab:orange', lw=1)
        row[1].plot(lags, c['real_acf'], 'k', lw=1.5, label='measured')
        row[1].set(title='autocorrelation, north', xlabel='lag (s)')
        row[1].legend(fontsize=8)
        r = np.sort(np.hypot(c['errors'][:, 0], c['errors'][:, 1]))
        for s in c['sims'][:40]:
            rs = np.sort(np.hypot(s[:, 0], s[:, 1]))
            row[2].plot(rs, np.linspace(0, 1, rs.size), color='tab:orange', alpha=0.15, lw=0.8)
        row[2].plot(r, np.linspace(0, 1, r.size), 'k', lw=1.5, label='measured')
        row[2].plot([], [], color='tab:orange', label='simulated (40 agents)')
        row[2].set(title='horizontal error, share below', xlabel='m')
        row[2].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _preset_rows():
    rows = []
    for name in PRESETS:
        f = typical(name)
        rows.append(f'| `{name}` | {f["rms_n"]:.1f} / {f["rms_e"]:.1f} | '
                    f'{f["median"]:.1f} ({f["median_lo"]:.1f}-{f["median_hi"]:.1f}) | '
                    f'{f["q95"]:.1f} ({f["q95_lo"]:.1f}-{f["q95_hi"]:.1f}) | '
                    f'{PRESETS[name]} |')
    return '\n'.join(rows)


def _check_row(label, result):
    """Return a table row of ``gps_error validate``'s figures for one held-out recording."""
    doc = result.to_dict()
    acf = ' / '.join(f'{doc[a]["acf_lags_inside_envelope"]:.0%}' for a in ('north', 'east'))
    quant = ' / '.join(f'{doc[a]["quantiles_inside_envelope"]:.0%}' for a in ('north', 'east'))
    return f'| {label} | {result.samples} | {acf} | {quant} | {result.joint_pct:.0f} |'


def _quantile_row(label, c):
    """Return a table row: measured horizontal quantiles beside the simulated ranges."""
    sim = ', '.join(f'{m:.1f} ({lo:.1f}-{hi:.1f})'
                    for m, lo, hi in zip(c['q_mid'], c['q_lo'], c['q_hi']))
    return f'| {label} | {", ".join(f"{v:.1f}" for v in c["q"])} | {sim} |'


def main(argv=None):
    """Write docs/model.md and docs/images/real-vs-simulated.png; exit 0."""
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--data', type=Path, default=Path(__file__).resolve().parents[1] / 'data')
    ap.add_argument('--out', type=Path, default=Path('.'))
    args = ap.parse_args(argv)
    phone = read_trace_csv(args.data / 'gsdc2020-mtv1-pixel4xlmodded.csv')
    walks = [read_trace_csv(p) for p in sorted(args.data.glob('snapper-walk-*.csv'))]
    held = next(i for i, w in enumerate(walks) if w.name == HELD_WALK)
    labels = occasions(walks)
    train = [str(args.data / w.name) for i, w in enumerate(walks) if labels[i] != labels[held]]
    walk_profile = ge.calibrate(train, population=True, within='ar', progress=False)
    phone_profile = ge.load_profile('phone-suburban-drive')
    cases = [('Pixel 4 XL, phone-suburban-drive', case(phone_profile, measured(phone))),
             (f'walk {HELD_WALK[-7:-4]} left out',
              case(walk_profile, measured(walks[held])))]
    checks = [ge.validate(phone_profile, args.data / phone.name, sims=VALIDATE_SIMS, seed=1),
              ge.validate(walk_profile, args.data / HELD_WALK, sims=VALIDATE_SIMS, seed=1)]
    draw(cases, args.out / 'docs' / 'images' / 'real-vs-simulated.png')
    page = TEMPLATE.page(
        preset_rows=_preset_rows(), agents=AGENTS, minutes=RUN_S // 60, sims=SIMS,
        held_walk=HELD_WALK, train_walks=len(train),
        check_rows='\n'.join([_check_row('Pixel 4 XL (another phone) against '
                                         '`phone-suburban-drive`', checks[0]),
                              _check_row(f'`{HELD_WALK}` against the other occasions\' walks',
                                         checks[1])]),
        validate_sims=VALIDATE_SIMS, quantile_rows='\n'.join(
            _quantile_row(label, c) for label, c in cases),
        phone_median=f'{cases[0][1]["q"][0]:.1f}',
        date=dt.date.today().isoformat(),
        machine=f'{platform.machine()}, Python {platform.python_version()}')
    (args.out / 'docs' / 'model.md').write_text(page)
    print(f'wrote {args.out / "docs" / "model.md"}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
