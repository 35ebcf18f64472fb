"""
The stated accuracy of the reported-accuracy model against measured phones (docs/accuracy.md).

For each trace whose phone stated an accuracy (``accuracy``) or an HDOP:
the two static GnssLogger logs (the 2016-08-22 one as the CSV in
``data/``, the 2016-06-30 one imported from ``raw/`` against the
test site's surveyed point, as ``gps_error import`` does) and the two GSDC
phones (HDOP). ``calibrate`` fits the profile (AR and ``reported_accuracy``)
on the first 70 %; ``validate``'s check (:mod:`reported_check`) simulates
``--sims`` traces on the last 30 % (same gaps) and sets the measured
coverage, stated-radius median and 95th percentile, and change rate beside
the simulated median and central 95 % range, with the measured value's
percentile.

    python tools/accuracy_evidence.py [--data data] [--sims 200]
"""

import argparse
from pathlib import Path
import sys

from gps_error_ros.fit.calibration import calibrate
from gps_error_ros.fit.validation import slice_trace, validate
from gps_error_ros.model.profiles import profile_from_dict
from gps_error_ros.traces.importing import import_recording
from gps_error_ros.traces.trace_io import read_trace_csv

CSVS = ('gmt-static-phone-2016-08-22.csv', 'gsdc2020-mtv1-pixel4.csv',
        'gsdc2020-mtv1-pixel4xlmodded.csv')
RAW_LOG = 'raw/gnsslogger/pseudoranges_log_2016_06_30_21_26_07.txt'
TEST_SITE = '37.422578,-122.081678,-28'      # the processing script's llaTrueDegDegM


def traces(data):
    """Yield (label, trace) of every phone that stated its accuracy."""
    yield CSVS[0], read_trace_csv(data / CSVS[0])
    trace, _ = import_recording('gnsslogger', data / RAW_LOG, TEST_SITE)
    yield f'{Path(RAW_LOG).name} (imported)', trace
    for name in CSVS[1:]:
        yield name, read_trace_csv(data / name)


def compare(label, trace, sims):
    """Return the lines of one trace's comparison."""
    fit = calibrate(slice_trace(trace, 0.0, 0.7))
    fitted = fit.reported
    section, evidence = fitted.section, fitted.evidence
    if section is None:
        return [f'{label}: no reported_accuracy fit ({evidence["reason"]})']
    profile = profile_from_dict(fit.profile_dict('evidence'))
    test = slice_trace(trace, 0.7, 1.0)
    res = validate(profile.model(), test, sims=sims, max_lag=10,
                   reported=profile.reported_accuracy)
    lines = [f'{label}: fitted on the first 70 % ({evidence["rows"]} rows): {section}',
             f'  training: coverage {evidence["coverage_measured"]}, values '
             f'{evidence["most_common"]}, follow SE {evidence["follow_se"]}',
             f'  held out {res.samples} fixes, {sims} simulations:']
    for name, d in res.reported.items():
        lines.append(f'  {name}: measured {d["measured"]:.4g}, simulated median '
                     f'{d["sim_median"]:.4g} (95 % {d["sim_lo"]:.4g} to {d["sim_hi"]:.4g}), '
                     f'percentile {d["percentile"]:g}')
    return lines


def main(argv=None):
    """Print the comparison for every phone that stated its accuracy."""
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--data', type=Path,
                    default=Path(__file__).resolve().parents[1] / 'data')
    ap.add_argument('--sims', type=int, default=200)
    args = ap.parse_args(argv)
    for label, trace in traces(args.data):
        print('\n'.join(compare(label, trace, args.sims)))
    return 0


if __name__ == '__main__':
    sys.exit(main())
