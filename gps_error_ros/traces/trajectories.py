"""
Trajectory files in and out: SUMO FCD output and trace CSV, streamed.

SUMO's ``--fcd-output`` is read with ``iterparse`` one ``<timestep>`` at a
time, so a large file never has to fit in memory. Positions are lon/lat when
SUMO wrote them with ``--fcd-output.geo`` (which its options comment at the
top of the file says: :func:`fcd_coordinates`); otherwise x/y metres of the
network, which ``--net NET.xml`` georeferences through its ``<location>``
element (``netOffset`` and ``projParameter``). A network without a
projection (``projParameter="!"``) is a flat metric plane: errors are added
to x (east) and y (north) directly.
"""

import csv
from pathlib import Path
import re
from typing import Any, Iterator, Optional, Sequence
import xml.etree.ElementTree as ET

import numpy as np
from pyproj import Transformer

from gps_error_ros.model.atomic import PathArg
from gps_error_ros.model.geodesy import offset
from gps_error_ros.model.state import FloatArray, Numbers

FCD_AGENTS = ('vehicle', 'person', 'container')


class TrajectoryError(ValueError):
    """A trajectory file that cannot be read as expected."""


class NetProjection:
    """The georeference of a SUMO network (its ``<location>`` element)."""

    def __init__(self, net_path: PathArg) -> None:
        net_path = Path(net_path)
        loc = None
        try:
            for _, elem in ET.iterparse(net_path, events=('start',)):
                if elem.tag == 'location':
                    loc = elem
                    break
        except (ET.ParseError, OSError) as exc:
            raise TrajectoryError(f'{net_path}: cannot read the network: {exc}') from None
        if loc is None:
            raise TrajectoryError(f'{net_path}: no <location> element: expected a '
                                  f'SUMO .net.xml')
        try:
            dx, dy = (float(v) for v in loc.get('netOffset', '0,0').split(','))
        except ValueError:
            raise TrajectoryError(f'{net_path}: <location netOffset> '
                                  f'{loc.get("netOffset")!r}: expected "x,y"') from None
        self.offset = (dx, dy)
        proj = loc.get('projParameter', '!').strip()
        self.geo = proj not in ('!', '')
        self._tf = Transformer.from_crs(proj, 'EPSG:4326', always_xy=True) \
            if self.geo else None

    def _transformer(self) -> Transformer:
        """Return the network's projection (a network without one has no geography)."""
        if self._tf is None:
            raise TrajectoryError('the network has no projParameter: its x/y are not '
                                  'geographic')
        return self._tf

    def to_lonlat(self, x: Numbers, y: Numbers) -> tuple[Any, Any]:
        """Return lon, lat of network x/y."""
        return self._transformer().transform(np.asarray(x) - self.offset[0],
                                             np.asarray(y) - self.offset[1])

    def to_xy(self, lon: Numbers, lat: Numbers) -> tuple[Any, Any]:
        """Return network x/y of lon, lat."""
        px, py = self._transformer().transform(lon, lat, direction='INVERSE')
        return np.asarray(px) + self.offset[0], np.asarray(py) + self.offset[1]


_SUMO_HEADER = re.compile(r'<!--(.*?)-->', re.S)
_GEO_OPTION = re.compile(r'<fcd-output\.geo\s+value="(true|1|yes|on)"', re.I)


def _before_root(path: PathArg, head_bytes: int) -> str:
    """Return the text before an FCD file's ``<fcd-export>`` (SUMO's options comment)."""
    try:
        with open(path, 'rb') as f:
            head = f.read(head_bytes).decode('utf-8', errors='replace')
    except OSError as exc:
        raise TrajectoryError(f'{path}: cannot open: {exc}') from None
    return head.split('<fcd-export', 1)[0]


def fcd_coordinates(path: PathArg, head_bytes: int = 1 << 16) -> Optional[str]:
    """
    Return 'lonlat' or 'xy' as SUMO's options comment says, or None.

    SUMO starts its outputs with a comment naming itself and holding the
    non-default options of the run as a ``<configuration>`` (run from the
    command line) or ``<sumoConfiguration>`` (run with ``-c``, as SUMO 1.28
    writes it); with ``--fcd-output.geo`` it lists ``<fcd-output.geo
    value="true"/>``. A file without that comment (written by hand or another
    tool) gives None.
    """
    for comment in _SUMO_HEADER.findall(_before_root(path, head_bytes)):
        if 'SUMO' in comment and ('<configuration' in comment
                                  or '<sumoConfiguration' in comment):
            return 'lonlat' if _GEO_OPTION.search(comment) else 'xy'
    return None


_NET_FILE = re.compile(r'<net-file\s+value="([^"]+)"')


def fcd_net_file(path: PathArg, head_bytes: int = 1 << 16) -> Optional[Path]:
    """
    Return the network SUMO's options comment names (``net-file``), or None.

    A relative name is looked for beside the FCD file, then as it is (SUMO
    resolves it against the directory it ran in); None when it is in
    neither place or the comment names none.
    """
    found = _NET_FILE.search(_before_root(path, head_bytes))
    if found is None:
        return None
    name = Path(found.group(1).split(',')[0].strip())
    for candidate in ([name] if name.is_absolute() else [Path(path).parent / name, name]):
        if candidate.is_file():
            return candidate
    return None


def check_fcd_root(path: PathArg) -> None:
    """Raise TrajectoryError unless the file's root element is <fcd-export>."""
    try:
        with open(path, 'rb') as f:
            _, root = next(ET.iterparse(f, events=('start',)))
    except OSError as exc:
        raise TrajectoryError(f'{path}: cannot open: {exc}') from None
    except (ET.ParseError, StopIteration) as exc:
        raise TrajectoryError(f'{path}: malformed XML: {exc}') from None
    if root.tag != 'fcd-export':
        raise TrajectoryError(f'{path}: root element <{root.tag}>: expected '
                              f'<fcd-export> (SUMO --fcd-output)')


def iter_fcd(path: PathArg, progress: Any = None) -> Iterator[tuple[float, Any, list[Any]]]:
    """
    Yield (time, element, agents) per ``<timestep>``.

    ``agents`` is a list of (id, x, y, child element). Elements are cleared
    after the caller resumes, so memory stays flat.
    """
    path = Path(path)
    try:
        f = open(path, 'rb')
    except OSError as exc:
        raise TrajectoryError(f'{path}: cannot open: {exc}') from None
    with f:
        try:
            context = ET.iterparse(f, events=('start', 'end'))
            _, root = next(context)
            if root.tag != 'fcd-export':
                raise TrajectoryError(f'{path}: root element <{root.tag}>: expected '
                                      f'<fcd-export> (SUMO --fcd-output)')
            last = None
            for event, elem in context:
                if event != 'end' or elem.tag != 'timestep':
                    continue
                try:
                    t = float(elem.get('time'))
                except (TypeError, ValueError):
                    raise TrajectoryError(f'{path}: <timestep time='
                                          f'{elem.get("time")!r}>: expected a number') from None
                if last is not None and t <= last:
                    raise TrajectoryError(f'{path}: timestep {t} after {last}: '
                                          f'expected increasing times')
                last = t
                agents = []
                for child in elem:
                    if child.tag in FCD_AGENTS and child.get('x') is not None:
                        try:
                            agents.append((child.get('id'), float(child.get('x')),
                                           float(child.get('y')), child))
                        except (TypeError, ValueError):
                            raise TrajectoryError(
                                f'{path}: time {t}: <{child.tag} id='
                                f'{child.get("id")!r}> has a non-numeric x/y') from None
                yield t, elem, agents
                if progress is not None:
                    progress.update(f.tell() - progress.done)
                elem.clear()
                root.clear()
        except ET.ParseError as exc:
            raise TrajectoryError(f'{path}: malformed XML: {exc}') from None


def add_errors_lonlat(lon: Numbers, lat: Numbers,
                      err: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Return (lon, lat) moved by north/east errors ``err`` (n, 2)."""
    lat2, lon2 = offset(lat, lon, err[:, 0], err[:, 1])
    return np.asarray(lon2), np.asarray(lat2)


class FcdWriter:
    """Write an FCD file with the same structure as the input."""

    def __init__(self, path: PathArg) -> None:
        self.f = open(path, 'w', encoding='utf-8')
        self.f.write('<?xml version="1.0" encoding="UTF-8"?>\n')
        self.f.write('<!-- positions with smartphone GPS errors added by '
                     'gps_error simulate -->\n<fcd-export>\n')

    def timestep(self, elem: Any, children: Sequence[tuple[Any, dict[str, str]]]) -> None:
        """
        Write a timestep: ``children`` are (element, attribute overrides).

        The overrides are formatted numbers, written as they are; the
        element's own attributes are escaped.
        """
        self.f.write(f'    <timestep time="{elem.get("time")}">\n')
        lines = []
        for child, over in children:
            own = child.attrib
            if _SPECIAL.search(''.join(own.values())):
                own = {k: _xml_escape(v) for k, v in own.items()}
            attrs = {**own, **over}
            text = ' '.join([f'{k}="{v}"' for k, v in attrs.items()])
            lines.append(f'        <{child.tag} {text}/>\n')
        self.f.write(''.join(lines))
        self.f.write('    </timestep>\n')

    def close(self) -> None:
        """Finish the file."""
        self.f.write('</fcd-export>\n')
        self.f.close()


_SPECIAL = re.compile('[&"<>]')


def _xml_escape(v: Any) -> str:
    return (str(v).replace('&', '&amp;').replace('"', '&quot;')
            .replace('<', '&lt;').replace('>', '&gt;'))


def read_truth_csv(path: PathArg) -> dict[str, Any]:
    """
    Read a CSV of true positions: t, truth_lat, truth_lon [, agent].

    Returns the rows as a dict of arrays; ``agent`` defaults to '' (one agent).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding='utf-8-sig')
    except OSError as exc:
        raise TrajectoryError(f'{path}: cannot read: {exc}') from None
    rows = list(csv.DictReader(text.splitlines()))
    need = ('t', 'truth_lat', 'truth_lon')
    if not rows or any(c not in rows[0] for c in need):
        raise TrajectoryError(f'{path}: expected columns {list(need)} '
                              f'(optional: agent, truth_alt)')
    out: dict[str, Any] = {'agent': [r.get('agent') or '' for r in rows]}
    for c in need:
        try:
            out[c] = np.array([float(r[c]) for r in rows])
        except ValueError:
            raise TrajectoryError(f'{path}: column {c!r} has a non-numeric '
                                  f'value') from None
    return out
