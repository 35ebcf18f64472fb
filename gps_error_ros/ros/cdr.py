"""
Fast paths over serialized (CDR) messages, for nodes serving crowds.

Deserializing a ``PoseStamped`` in rclpy costs ~40 us and building and
publishing a ``NavSatFix`` ~30 us; at thousands of agents per step that is
most of a core. These helpers read the few fields needed straight from the
bytes taken off a subscription, and write fixes by patching a serialized
template. Layouts follow the OMG CDR rules ROS 2 uses (XCDR1: primitives
aligned to their size relative to the start of the payload, after the
4-byte encapsulation header); tests compare them with rclpy's own
(de)serialization.
"""

from collections.abc import Sequence
import struct
from typing import Any

import numpy as np
from rclpy.serialization import serialize_message
from sensor_msgs.msg import NavSatFix

from gps_error_ros.model.state import BoolArray, FloatArray, IntArray, Numbers

HEADER = 4   # encapsulation: 2 bytes representation id, 2 bytes options


def _align(off: int, n: int) -> int:
    return (off + n - 1) // n * n


def _endian(raw: bytes) -> str:
    return '<' if raw[1] & 1 else '>'


def _after_header(raw: bytes, e: str) -> tuple[int, int]:
    """Return (stamp_ns, payload offset just after header.frame_id)."""
    sec, nsec, slen = struct.unpack_from(e + 'iII', raw, HEADER)
    return sec * 1_000_000_000 + nsec, 12 + slen


def pose_stamped(raw: bytes) -> tuple[Any, ...]:
    """Return (stamp_ns, x, y, z, qx, qy, qz, qw) of a serialized PoseStamped."""
    e = _endian(raw)
    stamp, off = _after_header(raw, e)
    return (stamp,) + struct.unpack_from(e + '7d', raw, HEADER + _align(off, 8))


def odometry(raw: bytes) -> tuple[Any, ...]:
    """Return (stamp_ns, x, y, z, qx, qy, qz, qw) of a serialized Odometry."""
    e = _endian(raw)
    stamp, off = _after_header(raw, e)
    off = _align(off, 4)
    (clen,) = struct.unpack_from(e + 'I', raw, HEADER + off)
    off = _align(off + 4 + clen, 8)
    return (stamp,) + struct.unpack_from(e + '7d', raw, HEADER + off)


def navsatfix(raw: bytes) -> tuple[Any, ...]:
    """Return (stamp_ns, status, lat, lon, alt) of a serialized NavSatFix."""
    e = _endian(raw)
    stamp, off = _after_header(raw, e)
    (status,) = struct.unpack_from(e + 'b', raw, HEADER + off)
    off = _align(_align(off + 1, 2) + 2, 8)
    return (stamp, status) + struct.unpack_from(e + '3d', raw, HEADER + off)


def frame_id(raw: bytes) -> str:
    """Return the ``header.frame_id`` of a serialized stamped message ('' if too short)."""
    if len(raw) < HEADER + 12:
        return ''
    (slen,) = struct.unpack_from(_endian(raw) + 'I', raw, HEADER + 8)
    return raw[HEADER + 12:HEADER + 12 + slen].rstrip(b'\0').decode(errors='replace')


def frame_ids_are(raws: Sequence[bytes], frame: str) -> BoolArray:
    """
    Return True per serialized stamped message whose ``header.frame_id`` is ``frame``.

    The string follows the stamp: a uint32 length (with its NUL) and the
    bytes. Little-endian messages are read with numpy in one pass; any other
    is read one by one. A message too short to hold it is False.
    """
    want = frame.encode() + b'\0'
    m, k = len(raws), len(want)
    out = np.zeros(m, dtype=bool)
    if m == 0:
        return out
    lens = np.fromiter(map(len, raws), dtype=np.int64, count=m)
    starts = np.zeros(m, dtype=np.int64)
    np.cumsum(lens[:-1], out=starts[1:])
    buf = np.frombuffer(b''.join([*raws, bytes(HEADER + 12 + k)]), dtype=np.uint8)
    little = (lens >= HEADER + 12 + k) & (buf[starts + 1] & 1 == 1)
    at = np.where(little, starts, 0)
    slen = _read(buf, at + HEADER + 8, '<u4')[:, 0]
    same = (buf[at[:, None] + HEADER + 12 + np.arange(k)] ==
            np.frombuffer(want, dtype=np.uint8)).all(axis=1)
    out[:] = little & (slen == k) & same
    for i in map(int, np.flatnonzero(~little & (lens >= HEADER + 12))):
        (slen_i,) = struct.unpack_from(_endian(raws[i]) + 'I', raws[i], HEADER + 8)
        out[i] = raws[i][HEADER + 12:HEADER + 12 + slen_i] == want
    return out


def _read(buf: Any, at: IntArray, dtype: Any, count: int = 1) -> Any:
    """Read ``count`` little-endian ``dtype`` values at each offset ``at``: (m, count)."""
    size = np.dtype(dtype).itemsize * count
    return buf[at[:, None] + np.arange(size)].view(dtype)


def parse_batch(kind: str,
                raws: Sequence[bytes]) -> tuple[IntArray, FloatArray, BoolArray]:
    """
    Parse many serialized messages of one kind at once.

    ``kind`` is ``'pose'``, ``'odometry'`` or ``'navsatfix'``; the values per
    message are those of :func:`pose_stamped`, :func:`odometry` or
    :func:`navsatfix` after the stamp. Returns ``(stamps, values, ok)``:
    stamps (m,) int64 ns, values (m, k) float64 and ok (m,) bool, False where
    a message is too short for its own lengths (such rows are zero). Little-
    endian messages are read with numpy in one pass; any other is parsed one
    by one.

    Long because it is one vectorised walk through the CDR layout, each
    field's offset depending on the one before; split, the pieces would trade
    a dozen arrays per call (the crowd node's hot path).
    """
    one, k = {'pose': (pose_stamped, 7), 'odometry': (odometry, 7),
              'navsatfix': (navsatfix, 4)}[kind]
    m = len(raws)
    stamps = np.zeros(m, dtype=np.int64)
    values = np.zeros((m, k))
    ok = np.zeros(m, dtype=bool)
    if m == 0:
        return stamps, values, ok
    lens = np.fromiter(map(len, raws), dtype=np.int64, count=m)
    starts = np.zeros(m, dtype=np.int64)
    np.cumsum(lens[:-1], out=starts[1:])
    # padded by more than the longest read (56 bytes), so that the reads of a
    # too-short message (its header, or offset 0 where a bound failed) stay
    # inside the buffer; bounds are checked per message below
    buf = np.frombuffer(b''.join([*raws, bytes(64)]), dtype=np.uint8)
    limit = starts + lens

    def inside(at: IntArray, n: int) -> tuple[BoolArray, IntArray]:
        good = (at >= starts) & (at + n <= limit)
        return good, np.where(good, at, 0)

    little = (lens >= HEADER + 12) & (buf[starts + 1] & 1 == 1)
    good = little.copy()
    base = starts + HEADER
    g, at = inside(base + 8, 4)
    good &= g
    off = 12 + _read(buf, at, '<u4')[:, 0].astype(np.int64)    # offset after frame_id
    if kind == 'odometry':
        off = _align(off, 4)
        g, at = inside(base + off, 4)
        good &= g
        off = off + 4 + _read(buf, at, '<u4')[:, 0]            # after child_frame_id
    if kind == 'navsatfix':
        g, at = inside(base + off, 1)
        good &= g
        status = buf[at].view(np.int8).astype(float)
        off = _align(_align(off + 1, 2) + 2, 8)
        nval = 3
    else:
        off = _align(off, 8)
        nval = 7
    g, at = inside(base + off, 8 * nval)
    good &= g
    vals = _read(buf, at, '<f8', nval)
    sec, nsec = _read(buf, base, '<i4')[:, 0], _read(buf, base + 4, '<u4')[:, 0]
    stamps[good] = sec[good].astype(np.int64) * 1_000_000_000 + nsec[good]
    if kind == 'navsatfix':
        values[good, 0] = status[good]
        values[good, 1:] = vals[good]
    else:
        values[good] = vals[good]
    ok[good] = True
    for i in np.flatnonzero(~little):          # big-endian or too short
        try:
            row = one(raws[int(i)])
        except (struct.error, IndexError):
            continue
        stamps[i], values[i], ok[i] = row[0], row[1:], True
    return stamps, values, ok


class FixTemplate:
    """
    Serialized NavSatFix with fixed frame, status and covariance.

    :meth:`render` writes stamps and positions of many fixes at once and
    returns one ``bytes`` per fix, ready for ``Publisher.publish``.
    """

    def __init__(self, frame_id: str, covariance: Sequence[float], covariance_type: int,
                 status: int, service: int) -> None:
        msg = NavSatFix()
        msg.header.frame_id = frame_id
        msg.status.status = status
        msg.status.service = service
        msg.position_covariance = list(covariance)
        msg.position_covariance_type = covariance_type
        self.template = np.frombuffer(serialize_message(msg), dtype=np.uint8)
        if not self.template[1] & 1:
            raise ValueError('expected little-endian CDR from this platform')
        slen = struct.unpack_from('<I', self.template.tobytes(), HEADER + 8)[0]
        off = _align(_align(12 + slen + 1, 2) + 2, 8)
        self.pos_off = HEADER + off

    def render(self, stamp_ns: int, lat: Numbers, lon: Numbers, alt: Numbers,
               cov: Numbers | None = None) -> list[bytes]:
        """
        Return a list of serialized fixes (one per row of lat/lon/alt).

        ``cov`` (m, 9), row-major ENU m^2 per fix, replaces the template's.
        """
        m = len(lat)
        buf = np.tile(self.template, (m, 1))
        stamp = np.empty((m, 2), dtype='<u4')
        stamp[:, 0] = np.int64(stamp_ns) // 1_000_000_000
        stamp[:, 1] = np.int64(stamp_ns) % 1_000_000_000
        buf[:, HEADER:HEADER + 8] = stamp.view(np.uint8).reshape(m, 8)
        pos = np.empty((m, 3), dtype='<f8')
        pos[:, 0], pos[:, 1], pos[:, 2] = lat, lon, alt
        buf[:, self.pos_off:self.pos_off + 24] = pos.view(np.uint8).reshape(m, 24)
        if cov is not None:         # the covariance follows the position directly
            c = np.ascontiguousarray(cov, dtype='<f8')
            buf[:, self.pos_off + 24:self.pos_off + 96] = c.view(np.uint8).reshape(m, 72)
        return [row.tobytes() for row in buf]
