"""
A small SUMO pedestrian scenario, built from SUMO's own tools.

For ``make demo-sumo`` and the live-loop test: ``netgenerate`` makes a street
grid with sidewalks and pedestrian crossings, ``randomTrips.py
--pedestrians`` makes people who walk between random edges, and a
``.sumocfg`` ties them together. netgenerate writes an unprojected network,
so the grid is placed on the Earth by writing a UTM projection and an offset
into its ``<location>`` element (what netconvert writes for a projected
network): x/y then are UTM metres less the offset, and SUMO's geo outputs and
``gps_error_sumo`` give real latitudes and longitudes.

Needs the optional extra ``sumo`` (the eclipse-sumo wheel).
"""

from collections.abc import Sequence
from dataclasses import dataclass, field
import os
from pathlib import Path
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
from pyproj import Proj

from gps_error_ros.model.atomic import PathArg
from gps_error_ros.model.geodesy import LocalTangentFrame
from gps_error_ros.model.state import FloatArray, Numbers
from gps_error_ros.traces.trajectories import NetProjection, TrajectoryError

INSTALL_HINT = ('SUMO is needed: pip install -r requirements-sumo.txt (the extra '
                '"sumo": eclipse-sumo, traci, sumolib)')


class SumoMissing(RuntimeError):
    """SUMO's binaries or tools are not installed."""


class ScenarioError(ValueError):
    """A SUMO configuration or network that cannot be used, or a bad datum."""


def sumo_home() -> Path:
    """Return SUMO_HOME: the eclipse-sumo wheel's, or the environment's."""
    try:
        import sumo
        return Path(sumo.SUMO_HOME)
    except ImportError:
        pass
    if os.environ.get('SUMO_HOME'):
        return Path(os.environ['SUMO_HOME'])
    raise SumoMissing(INSTALL_HINT)


def sumo_tool(name: str) -> str:
    """Return the path of a SUMO executable (``sumo``, ``netgenerate``)."""
    try:
        path = sumo_home() / 'bin' / name
        if path.exists():
            return str(path)
    except SumoMissing:
        pass
    found = shutil.which(name)
    if not found:
        raise SumoMissing(f'no {name} executable: {INSTALL_HINT}')
    return found


def net_file(sumocfg: PathArg) -> Path:
    """Return the network file a ``.sumocfg`` names (``<net-file value>``)."""
    try:
        root = ET.parse(sumocfg).getroot()
    except (ET.ParseError, OSError) as exc:
        raise ScenarioError(f'cannot read {sumocfg}: {exc}') from None
    for elem in root.iter('net-file'):
        value = elem.get('value', '').split(',')[0].strip()
        if value:
            return Path(sumocfg).parent / value
    raise ScenarioError(f'{sumocfg} names no <net-file>: expected a SUMO configuration '
                        f'with an input network')


class Georeference:
    """Network x/y to the published frame: ENU about a datum, and lon/lat."""

    def __init__(self, net: PathArg, datum: Sequence[float] | None) -> None:
        try:
            self.proj = NetProjection(net)
        except TrajectoryError as exc:
            raise ScenarioError(str(exc)) from None
        if not self.proj.geo and not datum:
            raise ScenarioError(
                f'parameter \'datum\' is required: the network {net} has no projection '
                f'(<location projParameter="!">), so where its x/y lie is unknown: '
                f'expected [lat_deg, lon_deg, alt_m] of its x=0, y=0')
        if datum:
            if len(datum) not in (2, 3):
                raise ScenarioError(f'parameter \'datum\': invalid value {list(datum)!r}: '
                                    f'expected [lat_deg, lon_deg] or [lat_deg, lon_deg, alt_m]')
            self.frame = LocalTangentFrame(*datum)
        else:
            lon, lat = self.proj.to_lonlat(0.0, 0.0)
            self.frame = LocalTangentFrame(float(lat), float(lon), 0.0)

    @property
    def datum(self) -> tuple[float, float, float]:
        """Return the ENU frame's datum: latitude, longitude, altitude."""
        return self.frame.datum

    def convert(self, x: Numbers, y: Numbers) -> tuple[FloatArray, ...]:
        """Return (east, north, up, lat, lon) arrays of network positions."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        if self.proj.geo:
            lon, lat = self.proj.to_lonlat(x, y)
            lat, lon = np.asarray(lat, dtype=float), np.asarray(lon, dtype=float)
            east, north, up = self.frame.to_enu(lat, lon, np.zeros_like(lat))
        else:
            east, north, up = x, y, np.zeros_like(x)
            lat, lon, _ = self.frame.to_geodetic(east, north, up)
        return (np.asarray(east), np.asarray(north), np.asarray(up),
                np.asarray(lat), np.asarray(lon))


def street_lines(net: PathArg, geo: Georeference) -> list[tuple[FloatArray, FloatArray]]:
    """Return the network's lanes and crossings as ENU (east, north) arrays."""
    lines: list[tuple[FloatArray, FloatArray]] = []
    skip = False
    for _, elem in ET.iterparse(net, events=('start',)):
        if elem.tag == 'edge':
            skip = elem.get('function') in ('internal', 'walkingarea')
        elif elem.tag == 'lane' and not skip and elem.get('shape'):
            xy = np.array([[float(v) for v in pt.split(',')[:2]]
                           for pt in elem.get('shape').split()])
            east, north, *_ = geo.convert(xy[:, 0], xy[:, 1])
            lines.append((east, north))
    return lines


@dataclass
class Scenario:
    """The files of a scenario and its people."""

    sumocfg: Path
    net: Path
    routes: Path
    persons: list[str]       # person ids, in departure order
    begin: float
    vehicles: list[str] = field(default_factory=list)     # vehicle ids, in departure order


def _run(cmd: Sequence[str], what: str, cwd: PathArg) -> None:
    # in the scenario's directory: randomTrips.py leaves a routes.rou.xml in its cwd
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd)
    if done.returncode != 0:
        raise RuntimeError(f'{what} failed ({" ".join(map(str, cmd))}):\n'
                           f'{done.stdout[-1500:]}{done.stderr[-1500:]}')


def georeference(net: PathArg, lat: float, lon: float) -> None:
    """Place network ``net``'s x=0, y=0 at (lat, lon): a UTM projection in <location>."""
    zone = int((lon + 180.0) // 6) + 1
    proj = (f'+proj=utm +zone={zone}{" +south" if lat < 0 else ""} +ellps=WGS84 '
            f'+datum=WGS84 +units=m +no_defs')
    x, y = Proj(proj)(lon, lat)
    text = Path(net).read_text()
    text, n = re.subn(r'<location netOffset="[^"]*"(.*?)projParameter="[^"]*"',
                      lambda m: f'<location netOffset="{-x:.2f},{-y:.2f}"{m.group(1)}'
                                f'projParameter="{proj}"', text, count=1)
    if n != 1:
        raise RuntimeError(f'{net}: no <location> element to georeference')
    Path(net).write_text(text)


def build_grid_scenario(out_dir: PathArg, grid: int = 3, length: float = 80.0,
                        depart_until: float = 30.0, period: float = 2.0, seed: int = 7,
                        lat: float = 40.75, lon: float = -73.99, begin: float = 1.0,
                        vehicle_period: float | None = None) -> Scenario:
    """
    Write a grid walking scenario to ``out_dir``; return its :class:`Scenario`.

    ``grid`` x ``grid`` junctions ``length`` m apart (sidewalks, crossings),
    one person every ``period`` s from ``begin`` to ``depart_until``, ids
    ``p0``, ``p1``, ... (valid ROS names). SUMO begins at ``begin`` (not 0,
    which ROS reads as "no clock yet"). With ``vehicle_period``, also one car
    trip every so many seconds (ids ``v0``, ``v1``, ...).
    """
    out = Path(out_dir).resolve()
    out.mkdir(parents=True, exist_ok=True)
    net, routes, cfg = out / 'grid.net.xml', out / 'persons.rou.xml', out / 'grid.sumocfg'
    _run([sumo_tool('netgenerate'), '--grid', '--grid.number', str(grid),
          '--grid.length', str(length), '--sidewalks.guess', 'true',
          '--crossings.guess', 'true', '--seed', str(seed), '-o', str(net)], 'netgenerate', out)
    georeference(net, lat, lon)
    _run([sys.executable, str(sumo_home() / 'tools' / 'randomTrips.py'), '-n', str(net),
          '--pedestrians', '--prefix', 'p', '-b', f'{begin:g}', '-e', f'{depart_until:g}',
          '-p', f'{period:g}', '--seed', str(seed), '-o', str(routes)], 'randomTrips.py', out)
    route_files = routes.name
    if vehicle_period:
        cars = out / 'vehicles.trips.xml'
        _run([sys.executable, str(sumo_home() / 'tools' / 'randomTrips.py'), '-n', str(net),
              '--prefix', 'v', '-b', f'{begin:g}', '-e', f'{depart_until:g}',
              '-p', f'{vehicle_period:g}', '--seed', str(seed + 1), '--validate',
              '-o', str(cars)], 'randomTrips.py (vehicles)', out)
        route_files += ',' + cars.name
    cfg.write_text(
        '<configuration>\n'
        f'    <input><net-file value="{net.name}"/><route-files value="{route_files}"/>'
        '</input>\n'
        f'    <time><begin value="{begin:g}"/><step-length value="1"/></time>\n'
        '</configuration>\n')
    persons = [p.get('id', '') for p in ET.parse(routes).getroot().iter('person')]
    if not persons:
        raise RuntimeError(f'{routes}: randomTrips.py made no persons')
    vehicles: list[str] = []
    if vehicle_period:
        vehicles = [v.get('id', '') for v in ET.parse(out / 'vehicles.trips.xml').getroot()
                    if v.tag in ('trip', 'vehicle')]
    return Scenario(cfg, net, routes, persons, begin, vehicles)
