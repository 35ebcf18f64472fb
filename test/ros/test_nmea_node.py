"""
The error node's NMEA stream: read back by the package's own import, and by gpsd.

The node streams each agent's steps on a loopback TCP port (``nmea_port``).
A client's capture, put through ``gps_error import nmea``, must give back
the NavSatFix positions and the outages; gpsd, a real consumer (Debian's
``gpsd``), connected to the port, must report the same positions and an
``eph`` that is the 95 % radius of the published covariance. The gpsd test
runs where gpsd is installed (``make gpsd-check`` installs it).
"""

import json
import re
import shutil
import socket
import subprocess
import time

from geometry_msgs.msg import PoseStamped
import numpy as np
import pytest
from sensor_msgs.msg import NavSatFix, NavSatStatus

from gps_error_ros.cli import main as cli
from gps_error_ros.model.accuracy import radius68
from gps_error_ros.traces.trace_io import read_trace_csv
from ros_harness import (covariances_ne, DATUM, DATUM_ARG, NS, pose_msg, stamp_ns, start,
                         unique_ns)

pytestmark = pytest.mark.integration
#: Simulated seconds at start: a date of 2026 (gpsd distrusts dates before its build).
START_S = 1_795_000_000
STEPS = 30


def _ports(node):
    """Return {agent: port} of the NMEA streams the node logged."""
    assert node.wait_output('NMEA 0183 on', timeout=20), node.stop()[1]
    one = re.findall(r'NMEA 0183 on tcp://127\.0\.0\.1:(\d+)', node._output)
    if one:                                     # a single agent: its port alone
        return {'': int(one[0])}
    found = re.findall(r'([\w/]+): tcp://127\.0\.0\.1:(\d+)', node._output)
    assert found, node._output
    return {name: int(port) for name, port in found}


def _drive(peer, pubs, boxes, seconds, pause=0.0, on_step=None):
    """Publish each agent's pose (walking north-east) then /clock; wait for every fix."""
    for k in range(START_S, START_S + seconds):
        for pub in pubs.values():
            pub.publish(pose_msg(k * NS, 1.1 * (k - START_S), 0.7 * (k - START_S)))
        peer.set_clock(k * NS)
        assert peer.spin_until(lambda: all(
            b and stamp_ns(b[-1].header.stamp) >= k * NS for b in boxes.values()), 5.0), k
        if on_step is not None:
            on_step()
        if pause:
            peer.spin_for(pause)


def test_the_stream_imports_back_to_the_fixes(tmp_path, peer):
    names = ['ann', 'bob']
    schedule = tmp_path / 'faults.yaml'
    schedule.write_text(f'- {{kind: outage, agent: bob, at: {START_S + 8}, duration: 4}}\n')
    ns = unique_ns()
    node = start(ns, 'profile:=DS5', DATUM_ARG, 'seed:=5', 'agents:=["ann", "bob"]',
                 'nmea_port:=0', 'covariance_mode:=conditional', f'fault_schedule:={schedule}')
    ports = _ports(node)
    assert ports['ann'] != ports['bob']
    clients = {n: socket.create_connection(('127.0.0.1', ports[n]), timeout=5) for n in names}
    captured = {n: bytearray() for n in names}

    def read():
        for n, c in clients.items():
            c.setblocking(False)
            try:
                while chunk := c.recv(65536):
                    captured[n] += chunk
            except BlockingIOError:
                pass

    pubs = {n: peer.publisher(PoseStamped, f'{ns}/{n}/pose') for n in names}
    fixes = {n: peer.collect(NavSatFix, f'{ns}/{n}/fix') for n in names}
    for n in names:
        peer.wait_connected(pubs[n], f'{ns}/{n}/fix', node)
    _drive(peer, pubs, fixes, STEPS, on_step=read)
    peer.spin_for(0.3)
    read()
    rc, out = node.stop()
    assert rc == 0, out
    for n in names:
        path = tmp_path / f'{n}.nmea'
        path.write_bytes(bytes(captured[n]))
        trace = tmp_path / f'{n}.csv'
        assert cli(['import', 'nmea', str(path), '--truth', f'{DATUM[0]},{DATUM[1]}',
                    '-o', str(trace)]) == 0
        got = read_trace_csv(trace)
        with_position = [f for f in fixes[n] if f.status.status == NavSatStatus.STATUS_FIX]
        assert len(got.t) == len(with_position) > 0, n
        stamps = np.array([stamp_ns(f.header.stamp) / NS for f in with_position])
        # the trace's t counts from its first fix
        np.testing.assert_allclose(got.t, stamps - stamps[0], atol=0.011)
        np.testing.assert_allclose(got.lat, [f.latitude for f in with_position], atol=1e-9)
        np.testing.assert_allclose(got.lon, [f.longitude for f in with_position], atol=1e-9)
        # each step is one epoch: GGA, GSA, GST (with a fix) and RMC; no fix: quality 0
        text = bytes(captured[n]).decode('ascii')
        assert text.count('$GPRMC') == len(fixes[n]) == STEPS
        assert text.count(',V,') == STEPS - len(with_position)
    assert sum(f.status.status == NavSatStatus.STATUS_NO_FIX for f in fixes['bob']) == 4


def _free_port():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


@pytest.mark.skipif(shutil.which('gpsd') is None or shutil.which('gpspipe') is None,
                    reason='gpsd not installed (Debian: gpsd, gpsd-clients; '
                           'make gpsd-check installs them)')
def test_gpsd_reads_the_node_stream(tmp_path, peer):
    ns = unique_ns()
    node = start(ns, 'profile:=DS5', DATUM_ARG, 'seed:=8', 'nmea_port:=0',
                 'covariance_mode:=conditional')
    port = _ports(node)['']
    pub = peer.publisher(PoseStamped, f'{ns}/pose')
    fixes = peer.collect(NavSatFix, f'{ns}/fix')
    peer.wait_connected(pub, f'{ns}/fix', node)
    control = _free_port()
    gpsd = subprocess.Popen(['gpsd', '-N', '-n', '-S', str(control), '-F',
                             str(tmp_path / 'ctl'), f'tcp://127.0.0.1:{port}'],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        time.sleep(0.5)
        pipe = subprocess.Popen(['gpspipe', '-w', f'127.0.0.1:{control}'],
                                stdout=subprocess.PIPE, text=True)
        time.sleep(0.5)
        _drive(peer, {'': pub}, {'': fixes}, STEPS, pause=0.2)
        time.sleep(1.0)             # the last epochs through gpsd
        pipe.terminate()
        report, _ = pipe.communicate(timeout=20)
    finally:
        gpsd.terminate()
        gpsd.wait(10)
    rc, out = node.stop()
    assert rc == 0, out
    reports = [json.loads(line) for line in report.splitlines() if line.startswith('{')]
    tpv = {r['time']: r for r in reports if r['class'] == 'TPV' and 'lat' in r and 'time' in r}
    seen = 0
    for f in fixes:
        t = stamp_ns(f.header.stamp) // NS
        key = time.strftime('%Y-%m-%dT%H:%M:%S.000Z', time.gmtime(t))
        if key not in tpv:
            continue
        seen += 1
        r = tpv[key]
        assert abs(r['lat'] - f.latitude) < 1e-7 and abs(r['lon'] - f.longitude) < 1e-7
        # gpsd's eph is the 95 % radius of the NavSatFix covariance (HDOP to 2 decimals)
        r95 = float(radius68(covariances_ne([f])[0], 0.95))
        assert r['eph'] == pytest.approx(r95, abs=0.005 * 19.0 + 0.01)
    assert seen >= STEPS // 2, report[-2000:]
