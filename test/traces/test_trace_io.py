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
