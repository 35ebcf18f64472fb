"""
gpsd, a real NMEA consumer, reads what ``simulate --out X.nmea`` writes.

The file is streamed on a loopback TCP socket at about five epochs a second,
gpsd (Debian's ``gpsd``, ``gpsd-clients``) reads it as a device
(``gpsd -N tcp://127.0.0.1:PORT``) and ``gpspipe -w`` gives its reports. Runs
where gpsd is installed; ``make gpsd-check`` installs it and runs this.
"""

import datetime as dt
import json
from pathlib import Path
import shutil
import socket
import subprocess
import threading
import time

import numpy as np
import pytest

from gps_error_ros.cli import main as cli
from gps_error_ros.model.accuracy import radius68
from gps_error_ros.traces.nmea import read_nmea
from gps_error_ros.traces.nmea_write import GPSD_UERE_M

pytestmark = pytest.mark.skipif(
    shutil.which('gpsd') is None or shutil.which('gpspipe') is None,
    reason='gpsd not installed (Debian: gpsd, gpsd-clients; make gpsd-check installs them)')
STEPS = 40
START = dt.datetime(2026, 11, 28, 12, 0, tzinfo=dt.timezone.utc)


def _free_port():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def _serve(server, path, done):
    """Stream ``path`` to gpsd's connection, an epoch (ending in RMC) every 0.2 s."""
    conn, _ = server.accept()
    with conn:
        for line in Path(path).read_bytes().split(b'\r\n'):
            if line:
                conn.sendall(line + b'\r\n')
                if line[3:6] == b'RMC':
                    time.sleep(0.2)
        done.wait(30)


def test_gpsd_reads_the_fixes_and_states_their_accuracy(tmp_path):
    src = tmp_path / 'truth.csv'
    src.write_text('t,agent,truth_lat,truth_lon\n' + ''.join(
        f'{t},w,{48.85 + 1e-5 * t!r},{2.35!r}\n' for t in range(STEPS)))
    nmea = tmp_path / 'w.nmea'
    assert cli(['simulate', '--profile', 'DS5', '--seed', '3', '--trajectories', str(src),
                '--out', str(nmea), '--covariance-mode', 'conditional',
                '--utc-start', START.isoformat()]) == 0
    server = socket.socket()
    server.bind(('127.0.0.1', 0))
    server.listen(1)
    done = threading.Event()
    feeder = threading.Thread(target=_serve, args=(server, nmea, done), daemon=True)
    feeder.start()
    port = _free_port()
    gpsd = subprocess.Popen(['gpsd', '-N', '-n', '-S', str(port), '-F', str(tmp_path / 'ctl'),
                             f'tcp://127.0.0.1:{server.getsockname()[1]}'],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        time.sleep(0.5)
        pipe = subprocess.run(['gpspipe', '-w', '-x', '15', f'127.0.0.1:{port}'],
                              capture_output=True, text=True, timeout=30)
    finally:
        done.set()
        gpsd.terminate()
        gpsd.wait(10)
        server.close()
    reports = [json.loads(line) for line in pipe.stdout.splitlines() if line.startswith('{')]
    tpv = {r['time']: r for r in reports if r['class'] == 'TPV' and 'lat' in r}
    gst = {r['time']: r for r in reports if r['class'] == 'GST'}
    fixes = read_nmea(nmea)
    key = [dt.datetime.fromtimestamp(t, dt.timezone.utc).strftime('%Y-%m-%dT%H:%M:%S.000Z')
           for t in fixes.t]
    seen = [i for i, k in enumerate(key) if k in tpv]
    # gpsd joins a little after the stream starts: most epochs, not every one
    assert len(seen) >= STEPS // 2, pipe.stdout[-2000:]
    for i in seen:
        r = tpv[key[i]]
        assert r['mode'] >= 2
        assert abs(r['lat'] - fixes.lat[i]) < 1e-7 and abs(r['lon'] - fixes.lon[i]) < 1e-7
        # its eph (95 %) is the 95 % radius of the fix's covariance, whose ellipse GST
        # carries (to the HDOP's two decimals: 19 m x 0.005)
        g = gst[key[i]]
        r95 = float(radius68(np.diag([g['major'] ** 2, g['minor'] ** 2]), 0.95))
        assert r['eph'] == pytest.approx(r95, abs=0.005 * GPSD_UERE_M + 0.01)
    assert len({tpv[key[i]]['eph'] for i in seen}) > 1     # conditional: each fix its own
