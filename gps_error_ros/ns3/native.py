"""
The C++ side of the ns-3 path (``gps_error_ns3.hpp``), compiled on first use.

ns-3's Python bindings (cppyy) compile C++ given as text. What runs per
packet is C++, so that a study of a thousand transmitters does not call
Python per packet:

- ``gps_error_ns3::Gps``: each node's current GPS fix, which
  :class:`~gps_error_ros.ns3.source.GpsSource` writes once per GPS epoch and
  any ns-3 application reads (``gps_error_ns3::Gps::HasFix(node)``,
  ``Position(node)``, ``Accuracy(node)``). The radio keeps the node's true
  position (its ``MobilityModel``).
- Personal safety messages (``StartSenders``, ``StartReceivers``): each
  sender broadcasts over UDP, at its rate, a message with the content of
  the SAE J2945/9 PSM (its id, a message count, the fix's time, position,
  stated accuracy, speed and heading), padded to a size that stands for
  the encoding and its security. A phone without a fix sends nothing.
  Receivers log what they received.
- Channel load (``TrackChannel``): each listed node's radio time not idle
  (receiving, sending or sensing the channel busy), from the PHY's state
  trace.
"""

from pathlib import Path
from typing import Any

#: Values per node in the GPS table: has-fix, fix time, lat, lon, x, y,
#: accuracy (68 % radius), semi-major, semi-minor, orientation, speed, heading.
FIELDS = ('fix', 't', 'lat', 'lon', 'x', 'y', 'accuracy', 'accuracy_major',
          'accuracy_minor', 'accuracy_orientation', 'speed', 'heading')

HEADER = Path(__file__).with_name('gps_error_ns3.hpp')
_loaded: list[Any] = []


def cpp() -> Any:
    """Return the namespace ``gps_error_ns3`` of the C++ side, compiling it on first use."""
    if not _loaded:
        from ns import ns       # ns-3 first: its headers and libraries
        import cppyy
        cppyy.cppdef(HEADER.read_text())
        space = ns.cppyy.gbl.gps_error_ns3
        if space.kFields != len(FIELDS):
            raise RuntimeError(f'{HEADER}: kFields {space.kFields}, expected {len(FIELDS)}')
        _loaded.append(space)
    return _loaded[0]
