"""
Library benchmark: error samples per second of the batch path.

For 1, 1e2, 1e4 and 1e6 agents: ``ARErrorModel.simulate`` (per-agent
streams, the path of ``gps_error simulate``), numpy's ``standard_normal`` for
the same number of draws (the floor: no model could draw its noise faster
with numpy), and a naive per-agent Python loop (one Generator per agent,
stepping the recursion in Python), all measured in this run. Each figure is
the best of a few repeats into a preallocated, already-touched buffer.

Then the reported velocity's side stream (a profile's ``velocity`` section,
the measured Pixel 4's shape: a speed table and a speed bias) for 1e2 and
1e4 agents: the error stepped per model step (``Velocity.errors``) with one
scale for every agent and a normal error, with each agent's own scale
(``scale_sd_log``), and with its own scale and bursts (``burst_share``,
``burst_ratio``); and the node's per-step report (``Velocity.report_parts``:
speed, SD and bias at the true speed), as velocity samples (east/north
pairs) per second, each variant's ratio to the first in the same run.
"""

import argparse
import json
import time

import numpy as np

from gps_error_ros.model.profiles import load_profile
from gps_error_ros.model.velocity import velocity_from_dict

CASES = ((1, 1_000_000), (100, 20_000), (10_000, 200), (1_000_000, 100))


def best_of(fn, repeats):
    best = float('inf')
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def naive(model, n_agents, n_steps, seed=0):
    """One Generator per agent, the AR recursion stepped in Python."""
    phi, mean, sw = model.phi, model.mean, np.sqrt(np.diag(model.innovation_cov))
    p = model.order
    out = np.empty((n_steps, n_agents, 2))
    for a in range(n_agents):
        rng = np.random.default_rng([seed, a])
        hist = [[0.0] * p, [0.0] * p]
        z = rng.standard_normal((n_steps, 2))
        for t in range(n_steps):
            for ax in range(2):
                h = hist[ax]
                v = sw[ax] * z[t, ax] + sum(phi[ax, i] * h[i] for i in range(p))
                hist[ax] = [v] + h[:-1]
                out[t, a, ax] = v + mean[ax]
    return out


#: The smoke run's cases (``--smoke``): seconds, so that make test keeps the script working.
SMOKE_CASES = ((1, 2_000), (100, 50))


def run(repeats=3, naive_budget=200_000, cases=CASES):
    model = load_profile('DS5').model()
    rng = np.random.default_rng(1)
    rows = []
    for n, steps in cases:
        keys = np.arange(n, dtype=np.uint64) * np.uint64(0x9E3779B97F4A7C15) + np.uint64(7)
        out = np.zeros((steps, n, 2))
        samples = out.size
        t_sim = best_of(lambda: model.simulate(keys, steps, out=out), repeats)
        t_floor = best_of(lambda: rng.standard_normal(out=out), repeats)
        # the naive loop is slow: time a slice of the same shape's work
        nn = max(1, min(n, naive_budget // steps))
        ns = min(steps, naive_budget // nn)
        t_naive = best_of(lambda: naive(model, nn, ns), 1) * (samples / (nn * ns * 2))
        row = {'agents': n, 'steps': steps, 'samples': samples,
               'simulate_Msps': samples / t_sim / 1e6,
               'floor_Msps': samples / t_floor / 1e6,
               'naive_Msps': samples / t_naive / 1e6,
               'ratio_to_floor': t_floor / t_sim,
               'speedup_over_naive': t_naive / t_sim}
        rows.append(row)
        print(f'{n:>9} agents x {steps:>9} steps: simulate {row["simulate_Msps"]:6.1f} M/s'
              f' | numpy floor {row["floor_Msps"]:6.1f} M/s | ratio {row["ratio_to_floor"]:.2f}'
              f' | naive loop {row["naive_Msps"]:6.2f} M/s (x{row["speedup_over_naive"]:.0f})',
              flush=True)
    return rows


#: A velocity section of the measured Pixel 4's shape (docs/calibration), with its scale.
VELOCITY = {'sigma': 0.13, 'phi': 0.16, 'lag_s': 0.3, 'course_lag_s': 0.6, 'standstill': 0.1,
            'speed_bias': [[7.0, 0.09], [13.6, -0.03], [27.2, -0.01]],
            'sigma_by_speed': [[7.0, 0.45], [13.6, 0.27], [22.1, 0.05], [27.2, 0.04]],
            'scale_sd_log': 0.17, 'burst_share': 0.055, 'burst_ratio': 4.3}
VELOCITY_CASES = ((100, 2_000), (10_000, 100))
SMOKE_VELOCITY_CASES = ((100, 20),)


def velocity_run(repeats=3, cases=VELOCITY_CASES):
    """Return the velocity side stream's figures (see the module doc)."""
    bursts = velocity_from_dict(VELOCITY)
    scaled = velocity_from_dict({k: v for k, v in VELOCITY.items() if 'burst' not in k})
    one = velocity_from_dict({k: v for k, v in VELOCITY.items()
                              if k != 'scale_sd_log' and 'burst' not in k})
    rows = []
    for n, steps in cases:
        keys = np.arange(n, dtype=np.uint64) * np.uint64(0x9E3779B97F4A7C15) + np.uint64(7)
        v_true = np.random.default_rng(2).uniform(-15.0, 15.0, (n, 2))
        w = one.errors(keys, 1)[0]
        pairs = n * steps
        t_one = best_of(lambda: one.errors(keys, steps), repeats)
        t_scaled = best_of(lambda: scaled.errors(keys, steps), repeats)
        t_bursts = best_of(lambda: bursts.errors(keys, steps), repeats)
        t_report = best_of(lambda: [bursts.report_parts(v_true, w) for _ in range(steps)],
                           repeats)
        row = {'agents': n, 'steps': steps, 'one_scale_Mpps': pairs / t_one / 1e6,
               'own_scale_Mpps': pairs / t_scaled / 1e6, 'bursts_Mpps': pairs / t_bursts / 1e6,
               'report_Mpps': pairs / t_report / 1e6, 'own_to_one': t_one / t_scaled,
               'bursts_to_one': t_one / t_bursts}
        rows.append(row)
        print(f'velocity {n:>6} agents x {steps:>5} steps: one scale '
              f'{row["one_scale_Mpps"]:6.2f} M/s | own scale {row["own_scale_Mpps"]:6.2f} M/s'
              f' (ratio {row["own_to_one"]:.2f}) | own scale and bursts '
              f'{row["bursts_Mpps"]:6.2f} M/s (ratio {row["bursts_to_one"]:.2f}) | report '
              f'{row["report_Mpps"]:6.2f} M/s', flush=True)
    return rows


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--json', help='write the figures here')
    p.add_argument('--smoke', action='store_true', help='tiny cases only (seconds)')
    args = p.parse_args()
    if args.smoke:
        rows = run(repeats=1, naive_budget=2_000, cases=SMOKE_CASES)
        velocity = velocity_run(repeats=1, cases=SMOKE_VELOCITY_CASES)
    else:
        rows, velocity = run(), velocity_run()
    if args.json:
        with open(args.json, 'w') as f:
            json.dump(rows + [dict(row, kind='velocity') for row in velocity], f, indent=1)


if __name__ == '__main__':
    main()
