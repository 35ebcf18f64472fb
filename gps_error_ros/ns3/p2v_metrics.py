"""
A P2V run's figures: messages delivered, channel load, warnings against the truth.

The warning rule is the vehicle's: every ``tick`` seconds, a moving vehicle
takes the newest message it received from each pedestrian (no older than
``max_age``), moves the pedestrian on from the message's fix by the speed
and heading it states, and its own position on at its speed. It warns of
a pedestrian whose predicted separation from it falls below ``radius``
within ``horizon`` seconds.

The truth is what happened: an encounter is a time a moving vehicle
really came within ``radius`` of a pedestrian (nobody yields in the
scenario). An encounter is caught (a hit) when the vehicle warned of that
pedestrian in the ``horizon`` before it, and the lead time is how long
before; else it is missed. A warning (a run of ticks warning of one
pedestrian) that no encounter follows within ``horizon`` is false.
"""

from dataclasses import dataclass
import math
from typing import Any

import numpy as np

from gps_error_ros.model.state import BoolArray, FloatArray, IntArray
from gps_error_ros.ns3.tracks import Tracks


@dataclass(frozen=True)
class Rule:
    """The warning rule and the truth's encounter, in metres and seconds."""

    radius: float = 3.0
    horizon: float = 4.0
    max_age: float = 1.0
    tick: float = 0.1


def wilson(k: int, n: int) -> tuple[float, float]:
    """Return the 95 % Wilson interval of a proportion ``k`` of ``n`` (NaNs for n = 0)."""
    if n == 0:
        return math.nan, math.nan
    z, p = 1.96, k / n
    mid = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return mid - half, mid + half


def encounters(peds: Tracks, cars: Tracks, ticks: FloatArray,
               rule: Rule) -> tuple[list[tuple[int, int, int, int]], FloatArray, FloatArray]:
    """
    Return the truth's encounters as (vehicle, pedestrian, first tick, last tick).

    Also returns the vehicles' positions and velocities on ``ticks``.
    Encounters already under way within ``horizon`` of the start are left
    out: nothing could have warned of them in time.
    """
    p = peds.at(ticks)
    v, vel = cars.at(ticks), cars.velocity(ticks)
    found = []
    for i in range(v.shape[0]):
        moving = np.hypot(vel[i, :, 0], vel[i, :, 1]) > 0.5
        close = (np.hypot(*(p - v[i][None]).transpose(2, 0, 1)) < rule.radius) & moving
        edge = np.diff(close.astype(np.int8), axis=1, prepend=0, append=0)
        for j in np.flatnonzero(close.any(axis=1)):
            starts = np.flatnonzero(edge[j] == 1)
            ends = np.flatnonzero(edge[j] == -1) - 1
            for a, b in zip(starts.tolist(), ends.tolist()):
                if ticks[a] >= rule.horizon:
                    found.append((i, int(j), a, b))
    return found, v, vel


def warnings(logs: dict[str, Any], n_peds: int, cars: FloatArray, vel: FloatArray,
             ticks: FloatArray, rule: Rule) -> BoolArray:
    """
    Return whether each vehicle warned of each pedestrian at each tick, (vehicles, peds, ticks).

    From the messages each vehicle received: their content is what the
    sender's phone stated when it sent them (``tx_*``).
    """
    keys, rx_keys = _keys(logs)
    order = np.argsort(keys)
    content = order[np.searchsorted(keys, rx_keys, sorter=order)]
    heading = np.radians(np.nan_to_num(logs['tx_heading']))
    speed = np.nan_to_num(logs['tx_speed'])
    mvx, mvy = speed * np.sin(heading), speed * np.cos(heading)
    out = np.zeros((cars.shape[0], n_peds, ticks.size), dtype=bool)
    by = np.lexsort((logs['rx_time'], logs['rx_from'], logs['rx_node']))
    group = (logs['rx_node'] * n_peds + logs['rx_from'])[by]
    bounds = np.searchsorted(group, np.arange(cars.shape[0] * n_peds + 1))
    for i in range(cars.shape[0]):
        moving = np.hypot(vel[i, :, 0], vel[i, :, 1]) > 0.5
        for j in range(n_peds):
            sel = by[bounds[i * n_peds + j]:bounds[i * n_peds + j + 1]]
            if not sel.size:
                continue
            last = np.searchsorted(logs['rx_time'][sel], ticks, side='right') - 1
            ok = (last >= 0) & moving
            got = sel[np.maximum(last, 0)]
            ok &= ticks - logs['rx_time'][got] <= rule.max_age
            c = content[got]
            ahead = ticks - logs['tx_fix_time'][c]
            rx = logs['tx_x'][c] + mvx[c] * ahead - cars[i, :, 0]
            ry = logs['tx_y'][c] + mvy[c] * ahead - cars[i, :, 1]
            wx, wy = mvx[c] - vel[i, :, 0], mvy[c] - vel[i, :, 1]
            tau = np.clip(-(rx * wx + ry * wy) / np.maximum(wx * wx + wy * wy, 1e-12),
                          0.0, rule.horizon)
            out[i, j] = ok & (np.hypot(rx + wx * tau, ry + wy * tau) < rule.radius)
    return out


def score(found: list[tuple[int, int, int, int]], warned: BoolArray, ticks: FloatArray,
          rule: Rule) -> dict[str, Any]:
    """Return hits, misses, lead times and false warnings of ``warned`` against ``found``."""
    h = int(round(rule.horizon / rule.tick))
    leads, hits = [], 0
    by_pair: dict[tuple[int, int], list[tuple[int, int]]] = {}
    for i, j, a, b in found:
        by_pair.setdefault((i, j), []).append((a, b))
        window = np.flatnonzero(warned[i, j, max(a - h, 0):a + 1])
        if window.size:
            hits += 1
            leads.append(float(ticks[a] - ticks[max(a - h, 0) + window[0]]))
    episodes, false = 0, 0
    for i, j in zip(*np.nonzero(warned.any(axis=2))):
        edge = np.diff(warned[i, j].astype(np.int8), prepend=0, append=0)
        spans = by_pair.get((int(i), int(j)), [])
        for a, b in zip(np.flatnonzero(edge == 1).tolist(),
                        (np.flatnonzero(edge == -1) - 1).tolist()):
            episodes += 1
            if not any(a <= e and b >= s - h for s, e in spans):
                false += 1
    return {'encounters': len(found), 'hits': hits, 'misses': len(found) - hits,
            'hit_rate': hits / len(found) if found else math.nan,
            'hit_rate_95': wilson(hits, len(found)), 'lead_s': leads,
            'warnings': episodes, 'false_warnings': false,
            'false_share_95': wilson(false, episodes)}


def delivery(logs: dict[str, Any], peds: Tracks, cars: Tracks,
             edges: FloatArray) -> tuple[IntArray, IntArray, FloatArray]:
    """
    Return messages sent and delivered per distance bin (``edges``, m), and each message's error.

    Every message sent counts once for every vehicle, at their true
    distance when it was sent. The error is the distance from the position
    a message states to where its sender truly was when sending it.
    """
    t, who = logs['tx_time'], logs['tx_node']
    truth = np.empty((t.size, 2))
    for j in range(len(peds.names)):
        sel = who == j
        truth[sel] = peds.of(j, t[sel])
    error = np.hypot(logs['tx_x'] - truth[:, 0], logs['tx_y'] - truth[:, 1])
    keys, rx_keys = _keys(logs)
    where = cars.at(t)
    sent = np.zeros(edges.size - 1, dtype=np.int64)
    got = np.zeros(edges.size - 1, dtype=np.int64)
    for i in range(len(cars.names)):
        d = np.hypot(*(truth - where[i]).T)
        bins = np.digitize(d, edges) - 1
        inside = (bins >= 0) & (bins < edges.size - 1)
        received = np.isin(keys, rx_keys[logs['rx_node'] == i])
        sent += np.bincount(bins[inside], minlength=edges.size - 1)
        got += np.bincount(bins[inside & received], minlength=edges.size - 1)
    return sent, got, error


def _keys(logs: dict[str, Any]) -> tuple[IntArray, IntArray]:
    """Return one key per message (its sender and count) for those sent and those received."""
    return (logs['tx_node'] * (1 << 32) + logs['tx_count'],
            logs['rx_from'] * (1 << 32) + logs['rx_count'])
