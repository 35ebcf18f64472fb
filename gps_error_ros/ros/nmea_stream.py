"""
The error node's NMEA 0183 stream: each agent's fixes on a TCP port of loopback.

With ``nmea_port`` set, agent ``i`` (the order of ``agents``; one agent:
``i = 0``) is served on ``127.0.0.1:nmea_port + i`` (``nmea_port`` 0: a
free port each, logged). Every client that connects gets, from then on,
each of the agent's steps as a receiver streams it: GGA, GSA, GST and RMC
(:func:`~gps_error_ros.traces.nmea_write.epoch_sentences`), the fix's
position, its covariance in GST and HDOP, speed and course with a
``velocity`` section, and a step without a fix as quality 0. The time of
the sentences is the fix's stamp read as Unix time (UTC).

No thread: the node's timer accepts waiting clients and writes to them
without blocking. A client that does not keep up (more than
``MAX_BACKLOG`` bytes waiting) or hangs up is dropped; the fixes go on.
"""

from collections.abc import Sequence
import datetime as dt
import math
import socket
from typing import Any

from gps_error_ros.traces.nmea_write import epoch_sentences

#: Bytes that may wait for a slow client before it is dropped (about 10 minutes at 1 Hz).
MAX_BACKLOG = 1 << 20
HOST = '127.0.0.1'


class _Client:
    """One connection and what it has not yet taken."""

    def __init__(self, conn: socket.socket) -> None:
        self.conn = conn
        self.waiting = b''


class NmeaServer:
    """A listening socket per agent on loopback, and its clients (see the module doc)."""

    def __init__(self, first_port: int, agents: int) -> None:
        self.listeners: list[socket.socket] = []
        self.clients: list[list[_Client]] = [[] for _ in range(agents)]
        self.dropped = 0            # clients dropped: hung up, or too slow
        try:
            for i in range(agents):
                s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                s.bind((HOST, first_port + i if first_port else 0))
                s.listen(8)
                s.setblocking(False)
                self.listeners.append(s)
        except OSError as exc:
            self.close()
            raise OSError(f'nmea_port {first_port}: cannot listen on {HOST}:'
                          f'{first_port + len(self.listeners) if first_port else 0} '
                          f'({exc.strerror}); choose a free port, or 0 for any') from None

    @property
    def ports(self) -> list[int]:
        """Return the port of each agent."""
        return [s.getsockname()[1] for s in self.listeners]

    def _accept(self, i: int) -> None:
        while True:
            try:
                conn, _ = self.listeners[i].accept()
            except (BlockingIOError, InterruptedError):
                return
            conn.setblocking(False)
            self.clients[i].append(_Client(conn))

    def send(self, i: int, data: bytes) -> None:
        """Give ``data`` to every client of agent ``i`` (accepting new ones first)."""
        self._accept(i)
        kept = []
        for c in self.clients[i]:
            c.waiting += data
            try:
                sent = c.conn.send(c.waiting)
                c.waiting = c.waiting[sent:]
            except (BlockingIOError, InterruptedError):
                pass
            except OSError:
                c.waiting = b'\0' * (MAX_BACKLOG + 1)       # hung up
            if len(c.waiting) > MAX_BACKLOG:
                self.dropped += 1
                c.conn.close()
                continue
            kept.append(c)
        self.clients[i] = kept

    def close(self) -> None:
        """Close every client and listener."""
        for clients in self.clients:
            for c in clients:
                c.conn.close()
        for s in self.listeners:
            s.close()
        self.clients = [[] for _ in self.clients]


def epoch_bytes(stamp_ns: int, lat: float, lon: float, alt: float, fix: bool,
                cov_ne: Sequence[Sequence[float]] | None, vertical_var: float,
                velocity: Any = None) -> bytes:
    """
    Return one step of an agent as NMEA bytes (CR LF after each sentence).

    ``velocity``: (east, north) m/s, or None.
    """
    when = dt.datetime(1970, 1, 1, tzinfo=dt.timezone.utc) + \
        dt.timedelta(microseconds=stamp_ns // 1000)
    speed = course = math.nan
    if velocity is not None and all(map(math.isfinite, velocity)):
        east, north = float(velocity[0]), float(velocity[1])
        speed = math.hypot(east, north)
        course = math.degrees(math.atan2(east, north)) % 360.0
    lines = epoch_sentences(when, lat, lon, alt, fix, cov_ne if fix else None,
                            math.sqrt(vertical_var) if vertical_var > 0 else math.nan,
                            speed=speed, course=course)
    return ('\r\n'.join(lines) + '\r\n').encode('ascii')


def open_for(node: Any, port: int, pattern: bool) -> NmeaServer | None:
    """Return the node's NMEA server of parameter ``nmea_port`` (None when -1), ports logged."""
    from gps_error_ros.ros.parameters import ConfigError
    if port < 0:
        return None
    if pattern:
        raise ConfigError('parameter \'nmea_port\': not with agent_pattern (agents that come '
                          'and go have no fixed port); list the agents in \'agents\'')
    try:
        server = NmeaServer(port, len(node.agents))
    except OSError as exc:
        raise ConfigError(f'parameter \'nmea_port\': {exc}') from None
    if node.agents == [None] or node.agents == ['']:      # one agent: its port alone
        node.get_logger().info(f'NMEA 0183 on tcp://{HOST}:{server.ports[0]}')
    else:
        node.get_logger().info('NMEA 0183 on ' + ', '.join(
            f'{n}: tcp://{HOST}:{p}' for n, p in zip(node.agents, server.ports)))
    return server
