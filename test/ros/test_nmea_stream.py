"""The NMEA server alone: clients come, read, hang up or stall, and the stream goes on."""

import socket
import time

import pytest

from gps_error_ros.ros.nmea_stream import epoch_bytes, MAX_BACKLOG, NmeaServer
from gps_error_ros.traces.nmea_write import checksum


def _epoch(k, fix=True):
    return epoch_bytes(1_795_000_000_000_000_000 + k * 1_000_000_000, 37.42, -122.08, 10.0,
                       fix, [[1.0, 0.0], [0.0, 2.0]], 4.0, (1.0, 1.0))


def _read(conn, epochs):
    """Return what ``conn`` receives until ``epochs`` RMC sentences have come."""
    conn.settimeout(2.0)
    got = b''
    while got.count(b'$GPRMC') < epochs or not got.endswith(b'\r\n'):
        got += conn.recv(65536)
    return got


def test_each_client_gets_the_epochs_from_when_it_came():
    server = NmeaServer(0, 2)
    try:
        early = socket.create_connection(('127.0.0.1', server.ports[0]))
        time.sleep(0.05)
        server.send(0, _epoch(0))
        late = socket.create_connection(('127.0.0.1', server.ports[0]))
        time.sleep(0.05)
        server.send(0, _epoch(1, fix=False))
        text = _read(early, 2).decode()
        assert text.count('$GPRMC') == 2 and ',V,' in text.split('$GPGGA')[2]
        assert _read(late, 1).decode().count('$GPRMC') == 1
        for line in text.split('\r\n'):
            if line:
                body, cs = line[1:].split('*')
                assert checksum(body) == cs
    finally:
        server.close()


def test_a_client_that_hangs_up_or_stalls_is_dropped_and_the_stream_goes_on():
    server = NmeaServer(0, 1)
    try:
        gone = socket.create_connection(('127.0.0.1', server.ports[0]))
        stalled = socket.create_connection(('127.0.0.1', server.ports[0]))
        stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        time.sleep(0.05)
        server.send(0, _epoch(0))
        gone.close()
        big = _epoch(1) * 2000          # about 600 kB per call: the stalled one falls behind
        for _ in range(20):
            server.send(0, big)
            if not server.clients[0]:
                break
        assert server.dropped == 2 and server.clients[0] == []
        fresh = socket.create_connection(('127.0.0.1', server.ports[0]))
        time.sleep(0.05)
        server.send(0, _epoch(2))
        assert b'$GPRMC' in _read(fresh, 1)
        assert MAX_BACKLOG == 1 << 20
    finally:
        server.close()


def test_a_port_in_use_is_named():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        s.listen(1)
        port = s.getsockname()[1]
        with pytest.raises(OSError, match=f'nmea_port {port}: cannot listen on 127.0.0.1:{port}'):
            NmeaServer(port, 1)
