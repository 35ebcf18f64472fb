"""The validation figure (the paper's Figs. 5, 7 and 8): envelopes and a map."""

from typing import Any

import numpy as np

from gps_error_ros.fit.validation import ValidationResult
from gps_error_ros.model.ar_model import AXES
from gps_error_ros.model.atomic import PathArg
from gps_error_ros.model.geodesy import LocalTangentFrame, offset


def _acf_panel(ax: Any, res: ValidationResult, ax_name: str) -> None:
    """Draw the measured autocorrelation in the simulated envelope."""
    env = res.acf_env[ax_name]
    ax.fill_between(res.lags, env[0], env[2], color='tab:blue', alpha=0.25,
                    label=f'simulated 95 % envelope ({res.sims} runs)')
    ax.plot(res.lags, env[1], color='tab:blue', lw=1, label='simulated median')
    ax.plot(res.lags, res.acf[ax_name], color='k', lw=1.5, label='measured')
    ax.axhline(0, color='0.6', lw=0.6)
    ax.set_xlabel('lag [s]')
    ax.set_ylabel('autocorrelation')
    ax.set_title(f'{ax_name} error: autocorrelation')
    ax.legend(fontsize=8)


def _qq_panel(ax: Any, res: ValidationResult, ax_name: str) -> None:
    """Draw the measured quantiles against the simulated ones, with envelope."""
    q, qenv = res.quant[ax_name], res.quant_env[ax_name]
    ax.fill_between(qenv[1], qenv[0], qenv[2], color='tab:orange', alpha=0.3,
                    label='simulated 95 % envelope')
    ax.plot(qenv[1], q, '.', color='k', ms=4, label='measured quantiles')
    lim = [min(qenv[0].min(), q.min()), max(qenv[2].max(), q.max())]
    ax.plot(lim, lim, color='0.5', lw=0.8, ls='--', label='y = x')
    ax.set_xlabel('simulated quantile (median of runs) [m]')
    ax.set_ylabel('measured quantile [m]')
    ax.set_title(f'{ax_name} error: quantile-quantile (1-99 %)')
    ax.legend(fontsize=8)


def map_window_of(res: ValidationResult, map_window: int) -> tuple[slice, LocalTangentFrame]:
    """
    Return the slice of samples the map shows, and its local frame.

    Up to ``map_window`` samples around the middle whose truth lies within
    ten error SDs of it (at least 2 m; at least 5 samples), so that the zoom
    follows the size of the errors, not the length of the road.
    """
    mid = len(res.truth[0]) // 2
    centre = LocalTangentFrame(float(res.truth[0][mid]), float(res.truth[1][mid]))
    ae, an, _ = centre.to_enu(res.truth[0], res.truth[1], np.zeros_like(res.truth[0]))
    radius = max(2.0, 10.0 * float(res.measured.std(axis=0).max()))
    near = np.hypot(ae, an) <= radius
    lo = hi = mid
    while lo > 0 and near[lo - 1] and mid - lo < map_window // 2:
        lo -= 1
    while hi < len(near) - 1 and near[hi + 1] and hi - mid < map_window // 2:
        hi += 1
    lo, hi = min(lo, max(0, mid - 2)), max(hi, min(len(near) - 1, mid + 2))
    return slice(lo, hi + 1), centre


def _map_panel(ax: Any, res: ValidationResult, map_window: int) -> None:
    """
    Draw truth, measured fixes and one simulated run around the middle.

    Where the truth moves further between samples than the errors' size (a
    car), no zoom of a map shows the errors: the panel then shows the fixes
    about the truth (the truth at the origin), which is the same picture in
    the receiver's own frame. Measured fixes are drawn on top.
    """
    win, frame = map_window_of(res, map_window)
    lat, lon = res.truth[0][win], res.truth[1][win]
    z = np.zeros_like(lat)
    te, tn, _ = frame.to_enu(lat, lon, z)
    sd = max(float(res.measured.std(axis=0).max()), 0.05)
    step = float(np.median(np.hypot(np.diff(te), np.diff(tn)))) if te.size > 1 else 0.0
    relative = step > sd
    if relative:
        win = slice(max(0, len(res.truth[0]) // 2 - map_window // 2),
                    len(res.truth[0]) // 2 + map_window // 2)
        me, mn = res.measured[win, 1], res.measured[win, 0]
        se, sn = res.simulated[win, 1], res.simulated[win, 0]
        ax.plot([0], [0], '+', color='0.2', ms=14, mew=2, label='ground truth')
        title = (f'fixes about the truth, {len(me)} samples\n'
                 f'(the truth moves {step:.0f} m a sample: no map shows the errors)')
    else:
        mlat, mlon = offset(lat, lon, res.measured[win, 0], res.measured[win, 1])
        slat, slon = offset(lat, lon, res.simulated[win, 0], res.simulated[win, 1])
        me, mn, _ = frame.to_enu(mlat, mlon, z)
        se, sn, _ = frame.to_enu(slat, slon, z)
        still = np.ptp(te) < 1.0 and np.ptp(tn) < 1.0      # a static receiver
        ax.plot(te, tn, 'x-' if still else '-', color='0.2', lw=1, ms=12, mew=2,
                label='ground truth')
        title = f'map: {len(lat)} samples from the middle of the trace'
    ax.plot(se, sn, '.', color='tab:green', ms=4, alpha=0.6,
            label='simulated fixes (one run)')
    ax.plot(me, mn, '.', color='tab:red', ms=5, alpha=0.9, zorder=3,
            label='measured fixes')          # on top: the data the model is judged on
    ax.set_aspect('equal', adjustable='datalim')
    ax.set_xlabel('east [m]' + (' of the truth' if relative else ''))
    ax.set_ylabel('north [m]' + (' of the truth' if relative else ''))
    ax.set_title(title, fontsize=10)
    # one marker size in the legend: the fixes' dots are small, the truth's cross
    # large, and a common scale made the cross cover the legend and the plot
    legend = ax.legend(fontsize=8, loc='best')
    for handle in legend.legend_handles:
        handle.set_markersize(LEGEND_MARKER_PT)


#: Marker size (points) of every entry in the map's legend.
LEGEND_MARKER_PT = 8


def validation_figure(res: ValidationResult, path: PathArg, title: str,
                      map_window: int = 180) -> None:
    """
    Write the validation PNG: ACF envelopes, QQ envelopes, map.

    The map shows ``map_window`` samples around the middle of the trace (the
    paper's Fig. 8 is zoomed in too: metre errors vanish on a long route).
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(15, 9), constrained_layout=True)
    gs = fig.add_gridspec(2, 3)
    for a, ax_name in enumerate(AXES):
        _acf_panel(fig.add_subplot(gs[a, 0]), res, ax_name)
        _qq_panel(fig.add_subplot(gs[a, 1]), res, ax_name)
    _map_panel(fig.add_subplot(gs[:, 2]), res, map_window)
    fig.suptitle(title)
    fig.savefig(path, dpi=80)
    plt.close(fig)
