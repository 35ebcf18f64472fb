"""The trace CSV reader: the status column of simulated outages."""

import pytest

from gps_error_ros.traces.trace_io import read_trace_csv, TraceError


def test_a_status_column_makes_no_fix_rows_gaps_and_names_a_bad_value(tmp_path):
    path = tmp_path / 'st.csv'
    path.write_text('t,status,lat,lon,truth_lat,truth_lon\n0,fix,1.0,2.0,1.0,2.0\n'
                    '1,no_fix,,,1.0,2.0\n2,fix,1.0,2.0,1.0,2.0\n')
    assert list(read_trace_csv(path).t) == [0.0, 2.0]
    path.write_text('t,status,lat,lon,truth_lat,truth_lon\n0,fix,1.0,2.0,1.0,2.0\n'
                    '1,lost,,,1.0,2.0\n2,fix,1.0,2.0,1.0,2.0\n')
    with pytest.raises(TraceError, match="line 3, column 'status'.*'lost'"):
        read_trace_csv(path)


def test_an_empty_fix_or_truth_is_a_gap_and_is_counted(tmp_path):
    from gps_error_ros.traces.loading import load_trace
    from gps_error_ros.traces.trace_io import read_trace_csv_counted
    path = tmp_path / 'gaps.csv'
    path.write_text('t,lat,lon,truth_lat,truth_lon\n0,1.0,2.0,1.0,2.0\n1,,,1.0,2.0\n'
                    '2,1.0,,1.0,2.0\n3,1.0,2.0,,\n4,1.0,2.0,1.0,2.0\n')
    trace, left_out = read_trace_csv_counted(path)
    assert list(trace.t) == [0.0, 4.0]
    assert left_out == {'no_fix': 2, 'no_truth': 1}
    notes = load_trace(path)[1]
    assert any('2 rows without a fix' in n and '1 without truth' in n for n in notes), notes
    # what stays out of range is still named by its line
    path.write_text('t,lat,lon,truth_lat,truth_lon\n0,,,1.0,2.0\n1,1.0,2.0,1.0,2.0\n'
                    '2,91.0,2.0,1.0,2.0\n3,1.0,2.0,1.0,2.0\n')
    with pytest.raises(TraceError, match='line 4: lat/lon out of range'):
        read_trace_csv(path)
    # a time cell may not be empty, and too few complete rows are refused
    path.write_text('t,lat,lon,truth_lat,truth_lon\n0,1.0,2.0,1.0,2.0\n,1.0,2.0,1.0,2.0\n')
    with pytest.raises(TraceError, match="line 3, column 't': expected a number"):
        read_trace_csv(path)
    path.write_text('t,lat,lon,truth_lat,truth_lon\n0,1.0,2.0,1.0,2.0\n1,,,1.0,2.0\n')
    with pytest.raises(TraceError, match='1 row.s. with a fix and its truth'):
        read_trace_csv(path)
