"""Every benchmark script runs in seconds and writes its figures, so none can rot unseen."""

import json
from pathlib import Path
import subprocess
import sys

import pytest

BENCH = Path(__file__).resolve().parents[2] / 'bench'


def _run(tmp_path, script, *args, timeout=240):
    out = tmp_path / 'figures.json'
    run = subprocess.run([sys.executable, str(BENCH / script), *args, '--json', str(out)],
                         capture_output=True, text=True, timeout=timeout, cwd=tmp_path)
    assert run.returncode == 0, run.stdout + run.stderr
    return run.stdout, json.loads(out.read_text())


def test_library_bench(tmp_path):
    printed, rows = _run(tmp_path, 'bench_library.py', '--smoke')
    errors = [r for r in rows if r.get('kind') != 'velocity']
    assert [r['agents'] for r in errors] == [1, 100]
    assert all(r['simulate_Msps'] > 0 and r['ratio_to_floor'] > 0 for r in errors)
    assert 'numpy floor' in printed
    velocity = [r for r in rows if r.get('kind') == 'velocity']
    assert [r['agents'] for r in velocity] == [100]
    assert all(r['own_scale_Mpps'] > 0 and r['own_to_one'] > 0 and r['bursts_to_one'] > 0
               for r in velocity)
    assert 'own scale' in printed


def test_zones_bench(tmp_path):
    printed, row = _run(tmp_path, 'bench_zones.py', '--smoke')
    assert row['agents'] == 200 and row['zones'] == 100 and row['ratio'] > 0
    assert 'without zones' in printed


def test_simulate_fcd_bench(tmp_path):
    printed, row = _run(tmp_path, 'bench_simulate_fcd.py', '--persons', '5', '--seconds', '30')
    assert row['persons'] == 5 and row['seconds'] == 30
    assert 'gps_error simulate on SUMO FCD' in printed


@pytest.mark.integration
def test_node_bench(tmp_path):
    printed, rows = _run(tmp_path, 'bench_node.py', '--agents', '1', '--modes', 'agents',
                         '--speed', '100')
    (row,) = rows
    assert row['agents'] == 1 and row['fixes_published'] > 0
    assert row['fixes_received_unique'] == row['fixes_published'], row
    assert row['fixes_published'] == row['agent_steps_with_truth'], row


def test_simulate_parquet_bench(tmp_path):
    printed, row = _run(tmp_path, 'bench_simulate_parquet.py', '--smoke')
    assert row['positions'] > 10_000 and row['simulate_s'] > 0 and row['floor_s'] > 0
    assert row['xml_positions'] > 1000 and row['dask_2_s'] > 0
    assert 'floor' in printed and 'Dask' in printed
