"""The figure of ``gps_error compare``: the held-out trace in every class's envelope."""

from collections.abc import Mapping
from typing import Any

import numpy as np

from gps_error_ros.fit.envelope import OUTAGE_MEASURES
from gps_error_ros.model.atomic import PathArg
from gps_error_ros.model.state import FloatArray, IntArray

OTHER = ('ne_correlation', 'sd_north', 'sd_east', 'horizontal_q50',
         'horizontal_q68', 'horizontal_q95', 'horizontal_q99') + OUTAGE_MEASURES


def _acf_rows(measures: Mapping[str, Mapping[str, float]],
              axis: str) -> tuple[IntArray, dict[str, FloatArray]]:
    names = sorted(n for n in measures if n.startswith(f'acf_{axis}_lag'))
    lags = np.array([int(n.rsplit('lag', 1)[1]) for n in names])
    cols = {k: np.array([measures[n][k] for n in names])
            for k in ('measured', 'sim_lo', 'sim_median', 'sim_hi')}
    return lags, cols


def compare_figure(doc: Mapping[str, Any], path: PathArg) -> PathArg:
    """
    Write a PNG: one column per model class, measured against its envelope.

    Rows: the autocorrelation north and east (the simulated central 95 %
    band, its median, the measured); then the measured value's percentile
    among the simulations for the other measures, outages included where
    counted (inside the band between 2.5 and 97.5 when the class simulates
    the phone well).
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    classes = doc['classes']
    fig, axes = plt.subplots(3, len(classes), figsize=(3.2 * len(classes), 9),
                             sharey='row', squeeze=False)
    for c, (name, cls) in enumerate(classes.items()):
        m = cls['fidelity']['measures']
        for r, axis in enumerate(('north', 'east')):
            a = axes[r, c]
            lags, v = _acf_rows(m, axis)
            a.fill_between(lags, v['sim_lo'], v['sim_hi'], color='tab:blue', alpha=0.25,
                           label='simulated 95 %')
            a.plot(lags, v['sim_median'], color='tab:blue', lw=1, label='simulated median')
            a.plot(lags, v['measured'], color='k', lw=1.5, label='held-out, measured')
            a.axhline(0, color='0.6', lw=0.5)
            a.set_xlabel('lag (s)')
            if c == 0:
                a.set_ylabel(f'{axis} ACF')
                a.legend(fontsize=7)
        a = axes[2, c]
        names = [n for n in OTHER if n in m]      # outages only where counted
        pct = [m[n]['percentile'] for n in names]
        a.axvspan(2.5, 97.5, color='tab:blue', alpha=0.15)
        inside = [2.5 <= p <= 97.5 for p in pct]
        a.scatter(pct, range(len(names)), c=['k' if i else 'tab:red' for i in inside],
                  zorder=3)
        a.set_xlim(-2, 102)
        a.set_yticks(range(len(names)))
        a.set_yticklabels([n.replace('horizontal_', '') for n in names], fontsize=8)
        a.set_xlabel('measured percentile in simulations')
        axes[0, c].set_title(f'{name}\nNLL {cls["heldout_nll_per_sample"]:.3f}, '
                             f'inside_95 {cls["fidelity"]["inside_95"]:.2f}', fontsize=10)
    fig.suptitle(f'{doc["input"]}: held-out part ({doc["test_samples"]} samples) '
                 f'against each class\'s simulations', fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path
