"""
Zone maps: which profile applies where.

A zone map is a GeoJSON FeatureCollection (RFC 7946, WGS84 longitude and
latitude) of Polygon or MultiPolygon features, each with a property
``profile`` (a built-in profile name, or the path of a profile YAML relative
to the map file) and an optional ``name``::

    {"type": "FeatureCollection",
     "default_profile": "DS1",
     "features": [
       {"type": "Feature",
        "properties": {"name": "7th Avenue", "profile": "DS5"},
        "geometry": {"type": "Polygon", "coordinates": [[[-73.99, 40.75], ...]]}}]}

Rules:

* A point is in a zone when it lies inside the polygon or on its edge.
* Where polygons overlap, the first feature in the file wins.
* Outside every polygon the *default* profile applies: the map's top-level
  ``default_profile`` when it has one (a foreign member, allowed by the
  GeoJSON specification), else the profile the user chose for the run (the
  node's ``profile``, ``simulate --profile``).
* Zone profiles set the error process (the AR parameters and the effects).
  What a phone reports about itself beyond the error (``availability``,
  ``velocity``, ``reported_accuracy``), its failed solutions
  (``gross_failures``) and the output's time line (``rate_hz``) come from
  the default profile, so a zone profile must have the default's
  ``rate_hz`` and ``motion_lag`` and none of those sections (unless it is
  the default profile itself, as in the fallback zones ``calibrate
  --zones`` writes). The same holds for ``population``: an agent's bias
  and scale are the receiver's, drawn once from the default profile's
  section and kept in every zone (:mod:`zoned`).

Point-in-polygon is vectorised over agents: one query of a shapely 2
``STRtree`` per step (the optional extra ``zones``).
"""

import json
from pathlib import Path
from typing import Any, NoReturn, Optional, Sequence

import numpy as np
import os

from gps_error_ros.model.profiles import load_profile, Profile, ProfileError
from gps_error_ros.model.protocol import OpaqueProcess
from gps_error_ros.model.state import FloatArray, IntArray, Numbers

#: The zone index of a point outside every polygon.
OUTSIDE = -1


class ZoneMapError(ValueError):
    """A zone map that cannot be used; the message names what and where."""


def _shapely() -> Any:
    try:
        import shapely
        import shapely.geometry  # noqa: F401  (shape(), used on GeoJSON)
    except ImportError:
        raise ZoneMapError(
            'zone maps need shapely 2, the optional extra "zones": '
            'pip install "gps_error_ros[zones]" (or shapely>=2)') from None
    return shapely


class ZoneMap:
    """
    A loaded, validated zone map: polygons, their profiles, and the default.

    Parameters
    ----------
    polygons
        The zones, in feature order.
    names
        Each zone's name.
    profiles
        Each zone's profile.
    default
        The map's ``default_profile``.
    path
        Where the map was read from.

    Attributes
    ----------
    names
        Each zone's ``name`` (``zone<i>`` when the feature has none).
    profiles
        Each zone's profile, in feature order.
    default
        The map's ``default_profile``, if it names one.
    path
        Where the map was read from (for messages).

    """

    def __init__(self, polygons: Sequence[Any], names: Sequence[str], profiles: Sequence[Profile],
                 default: Optional[Profile] = None, path: str = '<zones>') -> None:
        shapely = _shapely()
        self.polygons = np.asarray(polygons, dtype=object)
        self.names = list(names)
        self.profiles = list(profiles)
        self.default = default
        self.path = str(path)
        self._index = _CellIndex(self.polygons, shapely)

    def __len__(self) -> int:
        return len(self.names)

    def lookup(self, lat: Numbers, lon: Numbers) -> IntArray:
        """
        Return the zone index of each point (``OUTSIDE`` outside every polygon).

        Vectorised: one tree query for all points. Overlaps go to the first
        feature in the file.
        """
        lat = np.atleast_1d(np.asarray(lat, dtype=float))
        lon = np.atleast_1d(np.asarray(lon, dtype=float))
        out = np.full(lat.size, len(self), dtype=np.int64)
        ok = np.isfinite(lat) & np.isfinite(lon)
        if ok.any():
            rows = np.flatnonzero(ok)
            hit_pt, hit_zone = self._index.hits(lon[rows], lat[rows])
            np.minimum.at(out, rows[hit_pt], hit_zone)
        out[out == len(self)] = OUTSIDE
        return out


class _CellIndex:
    """
    Point-in-polygon for many points at once, without building point geometries.

    The map's bounding box is cut into ``cells`` x ``cells`` cells, each
    listing the polygons whose bounding box meets it. A point's candidates
    are its cell's polygons, tested with shapely's vectorised
    ``intersects_xy`` on prepared polygons (a point on an edge is inside).
    """

    def __init__(self, polygons: Any, shapely: Any, cells: int = 64) -> None:
        self.polygons, self.shapely = polygons, shapely
        shapely.prepare(polygons)
        b = shapely.bounds(polygons).reshape(-1, 4)
        self.x0, self.y0 = float(b[:, 0].min()), float(b[:, 1].min())
        self.cells = cells
        self.dx = max((float(b[:, 2].max()) - self.x0) / cells, 1e-12)
        self.dy = max((float(b[:, 3].max()) - self.y0) / cells, 1e-12)
        lo_x, hi_x = self._cell(b[:, 0], self.x0, self.dx), self._cell(b[:, 2], self.x0, self.dx)
        lo_y, hi_y = self._cell(b[:, 1], self.y0, self.dy), self._cell(b[:, 3], self.y0, self.dy)
        lists: list[list[int]] = [[] for _ in range(cells * cells)]
        for z in range(len(polygons)):
            for i in range(lo_x[z], hi_x[z] + 1):
                for j in range(lo_y[z], hi_y[z] + 1):
                    lists[i * cells + j].append(z)
        width = max(1, max(len(c) for c in lists))
        self.candidates = np.full((cells * cells, width), -1, dtype=np.int64)
        for c, zs in enumerate(lists):
            self.candidates[c, :len(zs)] = zs

    def _cell(self, v: FloatArray, v0: float, dv: float) -> IntArray:
        return np.clip(np.floor((v - v0) / dv), 0, self.cells - 1).astype(np.int64)

    def hits(self, x: FloatArray, y: FloatArray) -> tuple[IntArray, IntArray]:
        """Return (point index, polygon index) of every point inside a polygon."""
        inside_box = (x >= self.x0) & (x <= self.x0 + self.cells * self.dx) & \
            (y >= self.y0) & (y <= self.y0 + self.cells * self.dy)
        pts = np.flatnonzero(inside_box)
        cell = self._cell(x[pts], self.x0, self.dx) * self.cells + \
            self._cell(y[pts], self.y0, self.dy)
        cand = self.candidates[cell]                    # (m, width)
        pi, k = np.nonzero(cand >= 0)
        zi = cand[pi, k]
        inside = self.shapely.intersects_xy(self.polygons[zi], x[pts[pi]], y[pts[pi]])
        return pts[pi[inside]], zi[inside]


def _fail(path: str, where: str, expected: str, got: Any) -> NoReturn:
    got = repr(got)
    if len(got) > 80:
        got = got[:77] + '...'
    raise ZoneMapError(f'{path}: {where}: expected {expected}, got {got}')


def _load_zone_profile(path: str, where: str, spec: Any) -> Profile:
    """Load a zone's profile: a built-in name, or a path relative to the map."""
    if not isinstance(spec, str) or not spec.strip():
        _fail(path, where, 'a property "profile" naming a built-in profile or a '
              'profile YAML (relative to the map)', spec)
    candidate = Path(spec).expanduser()
    if not candidate.is_absolute() and candidate.suffix.lower() in ('.yaml', '.yml'):
        candidate = Path(path).parent / candidate
        spec = str(candidate)
    try:
        profile = load_profile(spec)
    except (ProfileError, OSError) as exc:
        raise ZoneMapError(f'{path}: {where}: {exc}') from None
    if not profile.fitted:
        raise ZoneMapError(f'{path}: {where}: profile {profile.name} has no fitted '
                           f'AR parameters (expected a fitted profile)')
    return profile


def _polygon(shapely: Any, path: str, where: str, geometry: Any) -> Any:
    if not isinstance(geometry, dict) or geometry.get('type') not in ('Polygon',
                                                                      'MultiPolygon'):
        _fail(path, f'{where} geometry', 'a GeoJSON Polygon or MultiPolygon',
              geometry if not isinstance(geometry, dict) else geometry.get('type'))
    try:
        poly = shapely.geometry.shape(geometry)
    except (ValueError, TypeError, AttributeError, IndexError) as exc:
        raise ZoneMapError(f'{path}: {where} geometry: not a valid {geometry["type"]} '
                           f'({exc})') from None
    if poly.is_empty:
        _fail(path, f'{where} geometry', 'a non-empty polygon', 'an empty one')
    minx, miny, maxx, maxy = poly.bounds
    if not (-180 <= minx <= maxx <= 180 and -90 <= miny <= maxy <= 90):
        _fail(path, f'{where} geometry', 'WGS84 [longitude, latitude] coordinates '
              '(longitude -180..180, latitude -90..90)', poly.bounds)
    if not poly.is_valid:
        reason = shapely.is_valid_reason(poly)
        raise ZoneMapError(f'{path}: {where} geometry: the polygon is not valid '
                           f'({reason}); expected a simple ring, e.g. not crossing '
                           f'itself')
    return poly


def zone_map_from_dict(raw: Any, path: str = '<zones>') -> ZoneMap:
    """Validate a parsed GeoJSON mapping and return a :class:`ZoneMap`."""
    shapely = _shapely()
    if not isinstance(raw, dict) or raw.get('type') != 'FeatureCollection':
        _fail(path, 'top level', 'a GeoJSON FeatureCollection',
              raw.get('type') if isinstance(raw, dict) else type(raw).__name__)
    features = raw.get('features')
    if not isinstance(features, list) or not features:
        _fail(path, 'features', 'a non-empty list of Polygon features', features)
    polygons, names, profiles = [], [], []
    for i, feature in enumerate(features):
        where = f'feature {i}'
        if not isinstance(feature, dict) or feature.get('type') != 'Feature':
            _fail(path, where, 'a GeoJSON Feature', feature)
        props = feature.get('properties') or {}
        if not isinstance(props, dict):
            _fail(path, f'{where} properties', 'a mapping', props)
        name = props.get('name', f'zone{i}')
        if not isinstance(name, str) or not name:
            _fail(path, f'{where} name', 'a non-empty string', name)
        where = f'feature {i} ({name})'
        polygons.append(_polygon(shapely, path, where, feature.get('geometry')))
        profiles.append(_load_zone_profile(path, where, props.get('profile')))
        names.append(name)
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        _fail(path, 'feature names', 'unique names', dup)
    default = raw.get('default_profile')
    if default is not None:
        default = _load_zone_profile(path, 'default_profile', default)
    return ZoneMap(polygons, names, profiles, default, path)


def load_zone_map(path: str | os.PathLike[str]) -> ZoneMap:
    """Read and validate a zone map file (GeoJSON)."""
    path = Path(path).expanduser()
    try:
        text = path.read_text(encoding='utf-8')
    except OSError as exc:
        raise ZoneMapError(f'{path}: cannot read the zone map ({exc.strerror})') from None
    try:
        raw = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ZoneMapError(f'{path}: not valid JSON (line {exc.lineno}, column '
                           f'{exc.colno}: {exc.msg}); expected a GeoJSON '
                           f'FeatureCollection') from None
    return zone_map_from_dict(raw, str(path))


def zone_models(zone_map: ZoneMap,
                profile: Profile) -> tuple[Profile, list[OpaqueProcess]]:
    """
    Return (the default profile, the error processes of the zones then the default's).

    ``profile`` is the run's own profile; the map's ``default_profile``
    replaces it when the map has one. The processes are the AR part and its
    effects alone: what the receiver does beyond them comes from the
    default profile (:func:`~.zoned.zoned_errors` wraps them). Raises
    :class:`ZoneMapError` for a zone profile the run cannot mix with the
    default (see the module doc).
    """
    default = zone_map.default or profile
    inner = default.process()
    models: list[OpaqueProcess] = []
    built: dict[str, OpaqueProcess] = {}
    for name, zp in zip(zone_map.names, zone_map.profiles):
        where = f'{zone_map.path}: zone {name!r} (profile {zp.name})'
        if zp.path == default.path:
            models.append(inner)        # the default itself (a fallback zone)
            continue
        if zp.rate_hz != default.rate_hz:
            raise ZoneMapError(f'{where}: rate_hz {zp.rate_hz} differs from the default '
                               f'profile {default.name}\'s {default.rate_hz}; expected '
                               f'the same model rate in every zone')
        for section, article in (('availability', 'an'), ('velocity', 'a'),
                                 ('reported_accuracy', 'a'), ('gross_failures', 'a'),
                                 ('population', 'a')):
            if getattr(zp, section) is not None:
                raise ZoneMapError(
                    f'{where}: has {article} {section} section; expected none: '
                    f'{section} comes from the default profile ({default.name}) '
                    f'everywhere')
        model = built.setdefault(zp.path, zp.process())   # may be shared
        if model.lag_s != inner.lag_s:
            raise ZoneMapError(f'{where}: motion_lag {model.lag_s} s differs from the '
                               f'default profile {default.name}\'s {inner.lag_s} s; '
                               f'expected the same lag in every zone')
        models.append(model)
    models.append(inner)
    return default, models
