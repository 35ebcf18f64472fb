"""
Error series from recorded fixes and truth, their statistics and figures.

Used by the demo to analyse the bag it recorded: the errors are measured
independently of the node, from the published fixes and the recorded truth.
"""

from collections.abc import Mapping
from typing import Any

import numpy as np

from gps_error_ros.fit import autocorrelation
from gps_error_ros.model import geodesy
from gps_error_ros.model.atomic import PathArg
from gps_error_ros.model.protocol import ErrorModel, S
from gps_error_ros.traces import bag_io

NS = 1_000_000_000


def errors_from_bag(bag: PathArg, datum: tuple[float, float, float],
                    pose_topic: str = '/pose', fix_topic: str = '/fix') -> dict[str, Any]:
    """
    Return fix errors (north, east metres) measured against recorded poses.

    The truth is the recorded pose stream (ENU metres about ``datum``),
    interpolated linearly to each fix's header stamp.
    """
    msgs = bag_io.read_messages(bag, [pose_topic, fix_topic])
    frame = geodesy.LocalTangentFrame(*datum)
    pt = np.array([_stamp(m.header.stamp) for _, m in msgs[pose_topic]])
    pe = np.array([m.pose.position.x for _, m in msgs[pose_topic]])
    pn = np.array([m.pose.position.y for _, m in msgs[pose_topic]])
    fixes = [m for _, m in msgs[fix_topic]]
    ft = np.array([_stamp(m.header.stamp) for m in fixes])
    flat = np.array([m.latitude for m in fixes])
    flon = np.array([m.longitude for m in fixes])
    te = np.interp(ft, pt, pe)
    tn = np.interp(ft, pt, pn)
    tlat, tlon, _ = frame.to_geodetic(te, tn, np.zeros_like(te))
    north, east = geodesy.difference(flat, flon, tlat, tlon)
    cov = np.array([list(m.position_covariance) for m in fixes]) if fixes \
        else np.zeros((0, 9))
    return {
        't': (ft - ft[0]) / NS if ft.size else ft.astype(float),
        'stamp_ns': ft, 'north': north, 'east': east,
        'truth_east': te, 'truth_north': tn,
        'fix_east': frame.to_enu(flat, flon, np.zeros_like(flat))[0],
        'fix_north': frame.to_enu(flat, flon, np.zeros_like(flat))[1],
        'covariance': cov,
        'cov_type': np.array([m.position_covariance_type for m in fixes]),
        'frame_ids': sorted({m.header.frame_id for m in fixes}),
        'pose_east': pe, 'pose_north': pn,
    }


def _stamp(s: Any) -> int:
    return s.sec * NS + s.nanosec


def summarise(err: Mapping[str, Any], model: ErrorModel[S],
              max_lag: int = 300) -> dict[str, Any]:
    """Return a dict comparing measured error statistics with the model."""
    out: dict[str, Any] = {'fixes': int(err['north'].size)}
    if err['north'].size < max_lag + 2:
        max_lag = max(1, err['north'].size - 2)
    theory_acf = model.autocorrelation(max_lag)
    steps = np.diff(err['stamp_ns'])
    out['gaps'] = int(np.sum(steps != np.median(steps))) if steps.size else 0
    for a, name in enumerate(('north', 'east')):
        x = err[name]
        acf = autocorrelation.autocorrelation(x, max_lag)
        out[name] = {
            'mean_m': float(x.mean()), 'theory_mean_m': float(model.mean[a]),
            'sd_m': float(x.std()), 'theory_sd_m': float(model.stationary_sd[a]),
            'rms_m': float(np.sqrt(np.mean(x ** 2))),
            'lag1_acf': float(acf[1]), 'theory_lag1_acf': float(theory_acf[1, a]),
        }
    return out


def demo_figure(err: Mapping[str, Any], model: ErrorModel[S], path: PathArg,
                title: str) -> None:
    """Write the demo's PNG: map, error time series, autocorrelation."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    max_lag = min(300, err['north'].size - 2)
    theory = model.autocorrelation(max_lag)
    fig = plt.figure(figsize=(14, 9), constrained_layout=True)
    gs = fig.add_gridspec(2, 3)
    ax = fig.add_subplot(gs[:, 0])
    ax.plot(err['pose_east'], err['pose_north'], '-', color='0.3', lw=1,
            label='ground truth (pose)')
    ax.plot(err['fix_east'], err['fix_north'], '.', ms=1.5, color='tab:red',
            alpha=0.5, label='published fixes')
    ax.set_aspect('equal')
    ax.set_xlabel('east of datum [m]')
    ax.set_ylabel('north of datum [m]')
    ax.set_title('map (local ENU frame)')
    ax.legend(loc='upper left', markerscale=6, fontsize=8)
    for row, name in enumerate(('north', 'east')):
        a = row
        axt = fig.add_subplot(gs[row, 1])
        axt.plot(err['t'] / 60.0, err[name], lw=0.6, color='tab:blue')
        m, sd = model.mean[a], model.stationary_sd[a]
        axt.axhline(m, color='k', lw=0.8, label='model mean')
        axt.axhline(m + 2 * sd, color='k', ls='--', lw=0.8, label='mean +- 2 sd')
        axt.axhline(m - 2 * sd, color='k', ls='--', lw=0.8)
        axt.set_xlabel('time [min]')
        axt.set_ylabel(f'{name} error [m]')
        axt.set_title(f'{name} error over time')
        axt.legend(fontsize=8, loc='upper right')
        axa = fig.add_subplot(gs[row, 2])
        acf = autocorrelation.autocorrelation(err[name], max_lag)
        lags = np.arange(max_lag + 1)
        axa.plot(lags, acf, color='tab:blue', label='produced errors')
        axa.plot(lags, theory[:, a], color='k', ls='--', label='profile theory')
        axa.axhline(0, color='0.6', lw=0.6)
        axa.set_xlabel('lag [s]')
        axa.set_ylabel('autocorrelation')
        axa.set_title(f'{name} error autocorrelation')
        axa.legend(fontsize=8)
    fig.suptitle(title)
    fig.savefig(path, dpi=90)
    plt.close(fig)
