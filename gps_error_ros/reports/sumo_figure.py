"""The figure of ``make demo-sumo``: SUMO's walkers, their fixes, their errors."""

from collections.abc import Sequence
from typing import Any

import numpy as np

from gps_error_ros.model.atomic import PathArg
from gps_error_ros.model.geodesy import difference
from gps_error_ros.sim.sumo_scenario import Georeference, street_lines

SHOWN = 4       # people drawn on the map


def live_figure(net: PathArg, geo: Georeference, rows: Sequence[Sequence[Any]], path: PathArg,
                title: str) -> None:
    """
    Write a PNG: the street grid with true walks and noisy fixes; errors over time.

    ``rows`` are (t, agent, lat, lon, truth_lat, truth_lon) of the recorded
    fixes; ``geo`` the scenario's georeference (its ENU frame is the map's).
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, (ax_map, ax_err) = plt.subplots(1, 2, figsize=(13, 6),
                                         gridspec_kw={'width_ratios': [1.1, 1]})
    for east, north in street_lines(net, geo):
        ax_map.plot(east, north, color='0.85', lw=0.8, zorder=1)
    people: dict[Any, list[tuple[Any, ...]]] = {}
    for t, p, lat, lon, tlat, tlon in rows:
        people.setdefault(p, []).append((t, lat, lon, tlat, tlon))
    longest = sorted(people, key=lambda p: -len(people[p]))[:SHOWN]
    colours = plt.cm.tab10(np.arange(SHOWN))
    for p, c in zip(longest, colours):
        a = np.asarray(people[p], dtype=float)
        te, tn, *_ = geo.frame.to_enu(a[:, 3], a[:, 4], np.zeros(len(a)))
        fe, fn, *_ = geo.frame.to_enu(a[:, 1], a[:, 2], np.zeros(len(a)))
        ax_map.plot(te, tn, color=c, lw=2, zorder=2, label=f'{p}: truth (SUMO)')
        ax_map.plot(fe, fn, '.', color=c, ms=4, alpha=0.7, zorder=3, label=f'{p}: fixes')
    ax_map.set_aspect('equal')
    ax_map.set_xlabel('east (m)')
    ax_map.set_ylabel('north (m)')
    ax_map.set_title(f'{len(people)} people; {SHOWN} longest walks drawn')
    ax_map.legend(fontsize=7, loc='upper left', ncol=2)
    for p in people:
        a = np.asarray(people[p], dtype=float)
        n, e = difference(a[:, 1], a[:, 2], a[:, 3], a[:, 4])
        shown = p in longest
        colour = colours[longest.index(p)] if shown else '0.7'
        ax_err.plot(a[:, 0], np.hypot(n, e), color=colour, lw=1.5 if shown else 0.6,
                    zorder=2 if shown else 1)
    ax_err.set_xlabel('SUMO time (s)')
    ax_err.set_ylabel('horizontal error of the fix (m)')
    ax_err.set_title('every person\'s error; each walks on its own stream')
    ax_err.grid(alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
