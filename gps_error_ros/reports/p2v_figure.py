"""The figure of the pedestrian-to-vehicle study (``make p2v``)."""

from typing import Any

import numpy as np

from gps_error_ros.model.atomic import PathArg


def p2v_figure(result: dict[str, Any], path: PathArg) -> None:
    """
    Write a PNG of four panels from the study's result (``gps_error_ros.ns3.p2v.study``).

    Messages delivered against distance; encounters caught and warnings
    false, with their 95 % intervals; the warnings' lead times; one
    pedestrian's true walk beside what its messages stated.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    conds = result['conditions']
    names = list(conds)
    colours = dict(zip(names, plt.cm.tab10(np.arange(len(names)))))
    fig, ax = plt.subplots(2, 2, figsize=(13, 10))
    edges = np.asarray(result['pdr_edges_m'])
    mid = (edges[1:] + edges[:-1]) / 2
    for i, (name, r) in enumerate(conds.items()):
        sent, got = np.asarray(r['pdr_sent'], float), np.asarray(r['pdr_delivered'], float)
        pdr = np.divide(got, sent, out=np.full(sent.size, np.nan), where=sent > 0)
        ax[0, 0].plot(mid, pdr, 'o-', color=colours[name], ms=3, lw=2.5 - 0.5 * i,
                      label=f"{name} (channel busy {np.mean(r['channel_busy']):.0%})")
    ax[0, 0].set(xlabel='distance from pedestrian to vehicle (m)', ylabel='delivered',
                 ylim=(0, 1.02), title='Messages delivered to vehicles (same for every condition)')
    ax[0, 0].legend(fontsize=8)
    x = np.arange(len(names))
    for k, (key, ci, label) in enumerate((('hit_rate', 'hit_rate_95', 'encounters caught'),
                                          (None, 'false_share_95', 'warnings false'))):
        vals = [r[key] if key else (r['false_warnings'] / r['warnings'] if r['warnings']
                                    else np.nan) for r in conds.values()]
        lo = [v - r[ci][0] for v, r in zip(vals, conds.values())]
        hi = [r[ci][1] - v for v, r in zip(vals, conds.values())]
        ax[0, 1].bar(x + (k - 0.5) * 0.38, vals, 0.38, yerr=[lo, hi], capsize=3,
                     label=label, color=('tab:green', 'tab:red')[k], alpha=0.8)
    ax[0, 1].set_xticks(x, names, fontsize=8)
    ax[0, 1].set(ylim=(0, 1.05), ylabel='share (95 % interval)',
                 title='Warnings against the truth')
    ax[0, 1].legend(fontsize=8)
    ahead = np.linspace(0.0, 4.0, 81)
    for name, r in conds.items():
        lead = np.asarray(r['lead_s'])
        share = [(lead >= a - 1e-9).sum() / max(r['encounters'], 1) for a in ahead]
        ax[1, 0].plot(ahead, share, color=colours[name], label=name)
    ax[1, 0].set(xlabel='warned at least this long before the encounter (s)',
                 ylabel='share of encounters', title='Warning lead time', ylim=(0, 1.02))
    ax[1, 0].legend(fontsize=8)
    truth = np.asarray(result['example']['truth_xy'])
    ax[1, 1].plot(truth[:, 0], truth[:, 1], 'k-', lw=2.5, label='truth')
    for name, r in conds.items():
        xy = np.asarray(r['example_xy'])
        if name != 'none' and xy.size:
            ax[1, 1].plot(xy[:, 0], xy[:, 1], '.-', color=colours[name], ms=3, lw=0.6,
                          label=name)
    ax[1, 1].set(xlabel='east (m)', ylabel='north (m)', aspect='equal',
                 title=f"Where {result['example']['pedestrian']}'s messages placed it")
    ax[1, 1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
