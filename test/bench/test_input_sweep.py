"""The input sweep's copies and its verdicts (the sweep itself: make input-sweep)."""

import importlib.util
from pathlib import Path
import random

from gps_error_ros.sim.synthetic import synthetic_trace
from gps_error_ros.traces.trace_io import read_trace_csv_counted, TraceError, write_trace_csv

SPEC = importlib.util.spec_from_file_location(
    'input_sweep', Path(__file__).resolve().parents[2] / 'bench' / 'input_sweep.py')
sweep = importlib.util.module_from_spec(SPEC)
SPEC.loader.exec_module(sweep)


def test_each_copy_is_the_alteration_it_names(tmp_path):
    src = write_trace_csv(synthetic_trace('none', 1, 600), tmp_path / 'w.csv')
    copies = {}
    for suffix, header, rows in sweep.variants(src, random.Random(1)):
        sweep._write(tmp_path / f'{suffix}.csv', header, rows)
        try:
            copies[suffix] = read_trace_csv_counted(tmp_path / f'{suffix}.csv')
        except TraceError as exc:          # none of the copies is malformed
            raise AssertionError(f'{suffix}: {exc}') from None
    whole = read_trace_csv_counted(src)[0]
    assert sorted(copies) == sorted(['head40', 'tail45', 'every3', 'failcluster', 'gaps',
                                     'scaled', 'unix', 'accbad', 'manyfail', 'still'])
    assert len(copies['every3'][0]) == len(whole.t[::3])
    assert copies['gaps'][1] == {'no_fix': 4, 'no_truth': 0}
    assert 'accuracy' not in copies['failcluster'][0].extra
    assert abs(copies['unix'][0].t[0] - (whole.t[0] + 1.7e9)) < 1e-3
    assert len(copies['still'][0]) == len(whole) + 300


def test_a_pass_is_quiet_or_one_named_refusal():
    assert sweep.judge(0, '') == ''
    assert sweep.judge(2, 'gps_error calibrate: w.csv: its fixes are 3 s apart\n') == ''
    assert sweep.judge(0, 'RuntimeWarning: Mean of empty slice\n') != ''
    assert sweep.judge(2, 'x.py:7: RuntimeWarning: ...\ngps_error calibrate: no\n') != ''
    assert sweep.judge(1, 'Traceback (most recent call last):\n') != ''
