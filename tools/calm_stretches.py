"""
Calm stretches: windows of a recording against what sampling alone gives its own AR.

A section of ``docs/generalisation.md`` (:mod:`generalisation` calls
:func:`calm_section`): each recording in windows of 300 s, the correlation
of the windows' SD with their lag-1 ACF, the lowest window lag-1 ACF and
the white floor under a persistent part, each beside its 95 % range over
traces of the recording's own stationary AR simulated on its time grid.
"""

import numpy as np
from page_template import Template

from gps_error_ros.fit.calibration import calibrate, errors_on_grid
from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import ARErrorModel

#: The windows of the floor analysis, s (the population's block), and its simulated traces.
FLOOR_WINDOW_S = 300
FLOOR_SIMS = 100
#: The section's words are the generalisation page's (tools/templates/generalisation.md).
TEMPLATE = Template('generalisation')


def _window_stats(segments, w=FLOOR_WINDOW_S):
    """Return (SD, lag-1 ACF, variance, lag-1 autocovariance) per window and axis, (k, 2) each."""
    v, c = [], []
    for seg in segments:
        for s0 in range(0, len(seg) - w + 1, w // 2):
            x = seg[s0:s0 + w] - seg[s0:s0 + w].mean(axis=0)
            v.append((x ** 2).mean(axis=0))
            c.append((x[1:] * x[:-1]).mean(axis=0))
    v, c = np.array(v), np.array(c)
    return np.sqrt(v), c / v, v, c


def _floor_fit(v, c):
    """Return (floor SD, the persistent part's lag-1 ACF) of ``v = floor^2 + c / rho``."""
    a = np.stack([np.ones_like(c), c], axis=1)
    (f2, slope), *_ = np.linalg.lstsq(a, v, rcond=None)
    return float(np.sqrt(max(f2, 0.0))), float(1.0 / slope) if slope > 0 else float('nan')


def _floor_rows(traces):
    """
    Return table rows: each (name, trace)'s windows of 300 s, against its own AR simulated.

    Per axis: the correlation of the windows' SD and lag-1 ACF, the lowest
    window lag-1 ACF, and the white floor under a persistent part that a
    regression of each window's variance on its lag-1 autocovariance gives;
    beside each, the 95 % range of the same figure over traces of the
    recording's stationary AR (``calibrate``) simulated on its time grid.
    """
    rows = []
    for name, trace in traces:
        grid = errors_on_grid(trace)
        model = ARErrorModel(*calibrate(trace).axis_params)
        keys = streams.agent_keys(0, [f'floor/{i}' for i in range(FLOOR_SIMS)])
        starts = [int(s - grid.starts[0]) for s in grid.starts]
        sim = model.simulate(keys, starts[-1] + len(grid.segments[-1]))
        figures, measured = [], _window_stats(grid.segments)
        for stats in [measured] + [_window_stats([sim[s:s + len(g), j] for s, g in
                                                  zip(starts, grid.segments)])
                                   for j in range(FLOOR_SIMS)]:
            sd, acf, v, c = stats
            figures.append([[np.corrcoef(sd[:, a], acf[:, a])[0, 1], acf[:, a].min(),
                             _floor_fit(v[:, a], c[:, a])[0]] for a in range(2)])
        f = np.array(figures)                                   # (1 + sims, axis, figure)
        lo, hi = np.nanpercentile(f[1:], [2.5, 97.5], axis=0)
        cells = [f'{f[0, a, k]:.2f} ({lo[a, k]:.2f} to {hi[a, k]:.2f})'
                 + ('' if lo[a, k] <= f[0, a, k] <= hi[a, k] else ' **out**')
                 for k in range(3) for a in range(2)]
        rho = [_floor_fit(measured[2][:, a], measured[3][:, a])[1] for a in range(2)]
        rows.append(f'| {name} | {len(measured[0])} | ' + ' | '.join(cells) +
                    f' | {rho[0]:.2f} / {rho[1]:.2f} |')
    return rows


def calm_section(traces):
    """Return the section's lines for ``traces``, (name, trace) pairs."""
    return [TEMPLATE.snippet('floor-head') + '\n',
            '| recording | windows | corr(SD, ACF 1) N | corr(SD, ACF 1) E | '
            'lowest ACF 1 N | lowest ACF 1 E | floor SD N (m) | floor SD E (m) | '
            'persistent part\'s ACF 1 N / E |', '|---|---|---|---|---|---|---|---|---|'] + \
        _floor_rows(traces) + ['', TEMPLATE.snippet('floor-tail') + '\n']
