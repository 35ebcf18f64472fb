"""Parameter tables: every node parameter declared once, with a descriptor."""

from collections.abc import Sequence
from dataclasses import dataclass
import math
from typing import Any, Optional

from rcl_interfaces.msg import (FloatingPointRange, IntegerRange,
                                ParameterDescriptor, ParameterType)
from rclpy.exceptions import (InvalidParameterTypeException,
                              InvalidParameterValueException,
                              ParameterException)
from rclpy.node import Node
from rclpy.parameter import Parameter

from gps_error_ros.model.ar_model import MAX_ORDER
from gps_error_ros.model.geodesy import GeodesyError, LocalTangentFrame

INT64_MAX = 2 ** 63 - 1
#: Seconds between repeats of a throttled per-message warning, in every node.
WARN_PERIOD_S = 5.0


class ConfigError(ValueError):
    """A parameter value that stops the node at start-up."""


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: name, default, type, description and bounds."""

    name: str
    default: Any
    type: int
    description: str
    read_only: bool = True
    low: Optional[float] = None
    high: Optional[float] = None
    choices: tuple[str, ...] = ()

    def descriptor(self) -> ParameterDescriptor:
        """Return the rcl_interfaces ParameterDescriptor of this parameter."""
        extra = ''
        if self.choices:
            extra = f' One of: {", ".join(self.choices)}.'
        d = ParameterDescriptor(
            name=self.name, type=self.type,
            description=self.description + extra, read_only=self.read_only)
        if self.low is not None and self.high is not None and \
                self.type == ParameterType.PARAMETER_DOUBLE:
            d.floating_point_range = [FloatingPointRange(
                from_value=float(self.low), to_value=float(self.high), step=0.0)]
        if self.low is not None and self.high is not None and \
                self.type == ParameterType.PARAMETER_INTEGER:
            d.integer_range = [IntegerRange(
                from_value=int(self.low), to_value=int(self.high), step=0)]
        return d

    def check(self, value: Any) -> str | None:
        """Return None if ``value`` is acceptable, else the reason."""
        if self.choices and value not in self.choices:
            return f'expected one of {list(self.choices)}'
        if self.low is not None and self.high is not None and isinstance(value, (int, float)):
            if not (math.isfinite(value) and self.low <= value <= self.high):
                return f'expected a value in [{self.low}, {self.high}]'
        if self.type == ParameterType.PARAMETER_STRING and self.name in (
                'frame_id', 'profile') and not str(value).strip():
            return 'expected a non-empty string'
        return None


TYPE_NAMES = {
    ParameterType.PARAMETER_STRING: 'a string',
    ParameterType.PARAMETER_DOUBLE: 'a number',
    ParameterType.PARAMETER_INTEGER: 'an integer',
    ParameterType.PARAMETER_DOUBLE_ARRAY: 'a list of numbers',
    ParameterType.PARAMETER_STRING_ARRAY: 'a list of strings',
}

ERROR_NODE_PARAMS = (
    ParamSpec('profile', 'DS5', ParameterType.PARAMETER_STRING,
              'Error-model profile: a built-in name (the paper\'s DS1, DS2, DS5, DS7; '
              'the presets phone-suburban-drive and snapshot-receiver-on-foot, see '
              'the presets page of the documentation; case-insensitive) or the path of a '
              'profile YAML.'),
    ParamSpec('input_type', 'pose', ParameterType.PARAMETER_STRING,
              'Ground truth input: pose (geometry_msgs/PoseStamped on "pose"), '
              'odometry (nav_msgs/Odometry on "odom"), navsatfix '
              '(noise-free sensor_msgs/NavSatFix on "fix_truth").',
              choices=('pose', 'odometry', 'navsatfix')),
    ParamSpec('datum', None, ParameterType.PARAMETER_DOUBLE_ARRAY,
              'WGS84 [lat_deg, lon_deg, alt_m] of the local map frame origin '
              '(ENU metres); required for pose and odometry input. '
              'alt may be omitted (0).'),
    ParamSpec('seed', -1, ParameterType.PARAMETER_INTEGER,
              'Seed of the error streams; the same seed gives the same errors. '
              '-1: a random seed, logged at start-up.', low=-1, high=INT64_MAX),
    ParamSpec('rate', 1.0, ParameterType.PARAMETER_DOUBLE,
              'Fixes per second of the ROS clock. The AR model keeps its own '
              '1 Hz grid: errors are held between model steps above 1 Hz and '
              'sampled below it.', low=0.01, high=100.0),
    ParamSpec('frame_id', 'gps', ParameterType.PARAMETER_STRING,
              'header.frame_id of the published fixes (the antenna frame).',
              read_only=False),
    ParamSpec('truth_frame', 'map', ParameterType.PARAMETER_STRING,
              'The frame_id the truth poses are expected in: ENU metres about the '
              'datum. Poses in another frame are counted on /diagnostics; empty: '
              'not checked.'),
    ParamSpec('other_frames', 'warn', ParameterType.PARAMETER_STRING,
              'A truth pose whose frame_id is not truth_frame: warn (taken as it '
              'is, one warning per frame name) or refuse (dropped).',
              choices=('warn', 'refuse')),
    ParamSpec('max_pose_age', 1.0, ParameterType.PARAMETER_DOUBLE,
              'Seconds past its stamp that the newest truth sample may be '
              'held when no newer one arrives; older truth gives no fix.',
              low=0.0, high=60.0),
    ParamSpec('fix_reliability', 'reliable', ParameterType.PARAMETER_STRING,
              'QoS reliability of the fix publishers. reliable: every '
              'subscriber matches and fixes lost in transport are re-sent. '
              'best_effort (as sensor-data QoS): only best-effort subscribers '
              'match, nothing is re-sent, and a crowd costs about a third less '
              'CPU; a crowd then publishes its fixes in bursts of 100, 1 ms '
              'apart, so that a subscriber\'s queue is not overrun.',
              choices=('reliable', 'best_effort')),
    ParamSpec('input_reliability', 'best_effort', ParameterType.PARAMETER_STRING,
              'QoS reliability of the truth subscriptions. best_effort (as '
              'sensor-data QoS): every publisher matches, but a message lost in '
              'transport is gone, and its step may get no fix; reliable: only '
              'reliable publishers match (gps_error_sumo, ros2 bag play by '
              'default), and lost messages are re-sent.',
              choices=('best_effort', 'reliable')),
    ParamSpec('covariance_mode', 'stationary', ParameterType.PARAMETER_STRING,
              'The fix covariance: stationary, the profile\'s unconditional error '
              'covariance (the same for every fix); conditional, the model\'s '
              'covariance of this fix\'s error given its state a step before (the '
              'innovation covariance, scaled by the regimes expected next; at a run\'s '
              'first step the stationary covariance, the law its error is drawn from), '
              'per fix, '
              'COVARIANCE_TYPE_KNOWN; reported, what the phone would state: the 68 % '
              'radius of the profile\'s reported_accuracy section as a circular '
              'covariance (per-axis SD radius / 1.51), per fix, '
              'COVARIANCE_TYPE_APPROXIMATED.',
              choices=('stationary', 'conditional', 'reported')),
    ParamSpec('covariance_about', 'truth', ParameterType.PARAMETER_STRING,
              'What the fix covariance covers. truth: the error about the truth, '
              'its mean included (the mean square error matrix C + m m^T: in '
              'stationary mode m is the profile\'s mean error, in conditional mode '
              'the error expected given the state a step before, in reported mode '
              'the profile\'s mean added to the stated circle), so that a consumer '
              'that takes the fix as truth plus zero-mean noise is right; mean: the '
              'error\'s spread about its mean alone (C). The vel covariance likewise '
              'adds, about the truth, the m m^T of the profile\'s velocity speed_bias.',
              choices=('truth', 'mean')),
    ParamSpec('zones', '', ParameterType.PARAMETER_STRING,
              'Zone map (GeoJSON polygons, each with a "profile" property): each '
              'agent\'s error follows the zone its truth is in, step by step, the '
              'error continuous across a boundary; profile (or the map\'s '
              'default_profile) applies outside every zone; each fix carries its '
              'zone\'s covariance. Empty: no zones. Needs shapely (extra "zones").'),
    ParamSpec('outage_output', 'no_fix', ParameterType.PARAMETER_STRING,
              'What a step in an outage (profile availability) publishes: no_fix, a '
              'NavSatFix with status NO_FIX, position NaN and covariance unknown '
              '(as robot_localization expects to drop); silent: nothing.',
              choices=('no_fix', 'silent')),
    ParamSpec('pose_frame_id', '', ParameterType.PARAMETER_STRING,
              'Also publish each fix as a geometry_msgs/PoseWithCovarianceStamped on '
              'fix_pose (A/fix_pose per agent), for estimators that take a pose '
              '(robot_localization\'s EKF): the fix\'s position in the local ENU frame '
              'of datum (x east, y north, z up), header.frame_id this value (the map '
              'frame, e.g. map), the fix\'s covariance in the position block and the '
              'orientation unknown (identity, variance 1e6 rad^2). No fix, no pose. '
              'Needs datum (also with input_type navsatfix). Empty: off.'),
    ParamSpec('nmea_port', -1, ParameterType.PARAMETER_INTEGER,
              'Also stream each agent\'s fixes as NMEA 0183 (GGA, GSA, GST, RMC; no fix: '
              'quality 0) on TCP 127.0.0.1, agent i of agents on nmea_port + i, for gpsd '
              '(gpsd -N tcp://127.0.0.1:PORT) and other NMEA readers. 0: a free port each, '
              'logged. -1: off.', low=-1, high=65535),
    ParamSpec('fault_schedule', '', ParameterType.PARAMETER_STRING,
              'A fault schedule (YAML) read at start: faults put on chosen agents at '
              'chosen times of the ROS clock (outage, frozen, offset, degraded, '
              'gross_failure; see the faults page of the documentation). Empty: none.'),
    ParamSpec('faults', '', ParameterType.PARAMETER_STRING,
              'Set at run time to add faults: one YAML entry or a list, e.g. '
              '"{kind: outage, agent: a1, at: 120, duration: 10}" (without at: from the '
              'next step). A bad entry is refused with the reason; accepted ones are '
              'added to the schedule. Reads back the last value set.',
              read_only=False),
    ParamSpec('agents', None, ParameterType.PARAMETER_STRING_ARRAY,
              'Agent names: for each agent A the node reads A/pose (A/odom, '
              'A/fix_truth) and publishes A/fix. Empty: one agent on the '
              'plain topics.'),
    ParamSpec('agent_profiles', None, ParameterType.PARAMETER_STRING_ARRAY,
              'Optional profile per agent, aligned with agents (default: '
              'profile for all).'),
    ParamSpec('start_time', -1.0, ParameterType.PARAMETER_DOUBLE,
              'ROS time (s) of the error streams\' first step, for every agent: the '
              'fixes then do not depend on when the node read its first clock '
              '(shards of a crowd; gps_error_sumo, whose SUMO begin time it should '
              'be; gps_error simulate, whose first step is the trajectory\'s first '
              'time). Clock readings before it are ignored; steps between it and the '
              'first reading are served from the truth already received (up to '
              '1000). -1: the first clock reading. The node logs the time the streams '
              'begin at.', low=-1.0, high=1e12),
    ParamSpec('agent_pattern', '', ParameterType.PARAMETER_STRING,
              'Serve agents as their truth topics appear: a topic name with one '
              '* for a whole name segment, e.g. /peds/*/pose; the segment is the '
              'agent\'s name, and its fixes go on the topic with the last segment '
              'replaced by fix (/peds/ped1/fix). A relative pattern is taken in '
              'the node\'s namespace. Not with agents. Empty: off.'),
    ParamSpec('agent_timeout', 10.0, ParameterType.PARAMETER_DOUBLE,
              'With agent_pattern: seconds of the ROS clock without truth after '
              'which an agent is stale; a stale agent whose topic has no publisher '
              'left is dropped (subscription, publisher and state released). One '
              'that comes back continues on its stream.', low=0.1, high=86400.0),
)


def _is_number(v: object) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _coerce(spec: ParamSpec, given: Any) -> Any:
    """
    Return ``given`` as the spec's type, or raise ConfigError naming it.

    Integers are accepted where a double is declared (``rate:=1`` means 1.0,
    ``datum:=[40, -73, 0]`` three doubles), as a user would expect.
    """
    t = spec.type
    ok = {
        ParameterType.PARAMETER_DOUBLE: _is_number,
        ParameterType.PARAMETER_INTEGER: lambda v: isinstance(v, int)
        and not isinstance(v, bool),
        ParameterType.PARAMETER_STRING: lambda v: isinstance(v, str),
        ParameterType.PARAMETER_DOUBLE_ARRAY: lambda v: not isinstance(v, str)
        and all(_is_number(x) for x in v),
        ParameterType.PARAMETER_STRING_ARRAY: lambda v: not isinstance(v, str)
        and all(isinstance(x, str) for x in v),
    }[t]
    try:
        good = ok(given)
    except TypeError:
        good = False
    if not good:
        shown = list(given) if hasattr(given, '__iter__') and \
            not isinstance(given, str) else given
        raise ConfigError(f'parameter {spec.name!r}: invalid value {shown!r}: '
                          f'expected {TYPE_NAMES[t]}{_range_text(spec)}')
    if t == ParameterType.PARAMETER_DOUBLE:
        return float(given)
    if t == ParameterType.PARAMETER_DOUBLE_ARRAY:
        return [float(x) for x in given]
    if t == ParameterType.PARAMETER_STRING_ARRAY:
        return [str(x) for x in given]
    return given


def _declare_one(node: Node, spec: ParamSpec) -> Any:
    """Declare one parameter from the table; return its (checked) value."""
    # What the user gave (command line or parameters file) is read first, as
    # the node declared it from the overrides (or through a dynamically typed
    # declaration), so that an integer for a double can be converted and a
    # wrong value named; then the parameter is declared for good with its
    # descriptor (type, range, read-only).
    if not node.has_parameter(spec.name):
        node.declare_parameter(spec.name, None, ParameterDescriptor(dynamic_typing=True))
    given = node.get_parameter(spec.name).value
    node.undeclare_parameter(spec.name)
    if given is None:
        value = spec.default
    else:
        value = _coerce(spec, given)
    initial = value if value is not None else {
        ParameterType.PARAMETER_DOUBLE_ARRAY: Parameter.Type.DOUBLE_ARRAY,
        ParameterType.PARAMETER_STRING_ARRAY: Parameter.Type.STRING_ARRAY,
    }.get(spec.type, Parameter.Type.STRING)
    try:
        node.declare_parameter(spec.name, initial, spec.descriptor(),
                               ignore_override=True)
    except (InvalidParameterTypeException, InvalidParameterValueException,
            ParameterException):
        raise ConfigError(f'parameter {spec.name!r}: invalid value {value!r}: '
                          f'expected {TYPE_NAMES.get(spec.type, "a value")}'
                          f'{_range_text(spec)}') from None
    if spec.type == ParameterType.PARAMETER_STRING_ARRAY and value is None:
        value = []
    reason = spec.check(value) if value is not None else None
    if reason:
        raise ConfigError(f'parameter {spec.name!r}: invalid value {value!r}: '
                          f'{reason}')
    return value


#: Parameters every rclpy node has; not the table's, not unknown.
BUILTIN_PARAMETERS = ('use_sim_time', 'start_type_description_service')


def declare(node: Node, specs: Sequence[ParamSpec]) -> dict[str, Any]:
    """
    Declare ``specs`` on ``node`` and return {name: value}.

    A node built with ``automatically_declare_parameters_from_overrides``
    holds every parameter the user gave; those the table does not know (a
    typo such as ``rat:=2.0``) are named in a warning rather than ignored
    silently.

    Parameters
    ----------
    node
        The node, built with ``automatically_declare_parameters_from_overrides``.
    specs
        The node's parameter table.

    Returns
    -------
    dict
        Each parameter's value, by name.

    Raises
    ------
    ConfigError
        Naming the parameter and the value, when an override has the wrong
        type or is out of range.

    """
    values = {spec.name: _declare_one(node, spec) for spec in specs}
    unknown = sorted(n for n in node.get_parameters_by_prefix('')
                     if n not in values and n not in BUILTIN_PARAMETERS
                     and not n.startswith('qos_overrides.'))
    if unknown:
        node.get_logger().warning(
            f'unknown parameter(s) {", ".join(unknown)} ignored: this node\'s '
            f'parameters are {", ".join(values)} (see --help)')
    return values


def _range_text(spec: ParamSpec) -> str:
    if spec.choices:
        return f' (one of {list(spec.choices)})'
    if spec.low is not None:
        return f' in [{spec.low}, {spec.high}]'
    return ''


def spec_by_name(specs: Sequence[ParamSpec]) -> dict[str, ParamSpec]:
    """Return {name: ParamSpec}."""
    return {s.name: s for s in specs}


CALIBRATION_NODE_PARAMS = (
    ParamSpec('input_type', 'pose', ParameterType.PARAMETER_STRING,
              'Ground truth input: pose (PoseStamped on "pose"), odometry '
              '(Odometry on "odom"), navsatfix (NavSatFix on "fix_truth"). '
              'Measured fixes come on "fix".',
              choices=('pose', 'odometry', 'navsatfix')),
    ParamSpec('datum', None, ParameterType.PARAMETER_DOUBLE_ARRAY,
              'WGS84 [lat_deg, lon_deg, alt_m] of the truth frame origin; '
              'required for pose and odometry input.'),
    ParamSpec('output', 'calibrated_profile.yaml', ParameterType.PARAMETER_STRING,
              'Profile YAML written on ~/calibrate and at shutdown. Beside it: '
              '<stem>.trace.csv (paired trace), <stem>.fixes.csv and '
              '<stem>.truth.csv (everything received).'),
    ParamSpec('name', '', ParameterType.PARAMETER_STRING,
              'Profile name (default: the output file stem).'),
    ParamSpec('order', 0, ParameterType.PARAMETER_INTEGER,
              'AR order; 0 lets the PACF choose per axis.', low=0, high=MAX_ORDER),
    ParamSpec('max_order', 10, ParameterType.PARAMETER_INTEGER,
              'Largest order the PACF may choose.', low=1, high=MAX_ORDER),
    ParamSpec('max_truth_gap', 0.0, ParameterType.PARAMETER_DOUBLE,
              'Longest truth interval (s) bridged by interpolation; 0: three '
              'times the median interval, at least 1.5 s.', low=0.0, high=3600.0),
    ParamSpec('input_reliability', 'best_effort', ParameterType.PARAMETER_STRING,
              'QoS reliability of the fix and truth subscriptions. best_effort: '
              'every publisher matches (sensor drivers publish best effort), but '
              'a message lost in transport is gone; reliable: only reliable '
              'publishers match (gps_error_play, ros2 bag play by default), and '
              'lost messages are re-sent, so a replayed recording arrives whole.',
              choices=('best_effort', 'reliable')),
)

SUMO_NODE_PARAMS = (
    ParamSpec('sumocfg', '', ParameterType.PARAMETER_STRING,
              'The SUMO scenario (.sumocfg) to run; required.'),
    ParamSpec('sumo_args', None, ParameterType.PARAMETER_STRING_ARRAY,
              'More SUMO command-line options, e.g. ["--fcd-output", "fcd.xml", '
              '"--fcd-output.geo", "true"].'),
    ParamSpec('sumo_binary', '', ParameterType.PARAMETER_STRING,
              'The sumo executable; empty: the one of the eclipse-sumo wheel, '
              'else sumo on PATH.'),
    ParamSpec('person_prefix', '/peds', ParameterType.PARAMETER_STRING,
              'Each person P\'s truth goes on PREFIX/P/pose (or PREFIX/P/fix_truth).'),
    ParamSpec('vehicle_prefix', '', ParameterType.PARAMETER_STRING,
              'Each vehicle V\'s truth goes on PREFIX/V/pose; empty: vehicles '
              'are not published.'),
    ParamSpec('output_type', 'pose', ParameterType.PARAMETER_STRING,
              'pose: geometry_msgs/PoseStamped in the local ENU frame of datum '
              '(yaw from SUMO\'s heading); navsatfix: noise-free '
              'sensor_msgs/NavSatFix on fix_truth.', choices=('pose', 'navsatfix')),
    ParamSpec('datum', None, ParameterType.PARAMETER_DOUBLE_ARRAY,
              'WGS84 [lat_deg, lon_deg, alt_m] of the ENU frame of the poses; give '
              'the error node the same. Default: the network\'s x=0, y=0 through '
              'its <location>; required for a network without a projection, whose '
              'x/y are then taken as east/north metres from it.'),
    ParamSpec('frame_id', 'map', ParameterType.PARAMETER_STRING,
              'header.frame_id of the poses.'),
    ParamSpec('speed', 1.0, ParameterType.PARAMETER_DOUBLE,
              'Simulated seconds per wall second; 0: as fast as SUMO and ROS go.',
              low=0.0, high=1e6),
    ParamSpec('wait_for_clock', 0, ParameterType.PARAMETER_INTEGER,
              'Before the first step, wait until /clock has this many subscribers '
              '(e.g. 1 for an error node started first, so that its first step is '
              'SUMO\'s first). 0: do not wait.', low=0, high=1000),
    ParamSpec('match_node', 'gps_error_node', ParameterType.PARAMETER_STRING,
              'With match_timeout: the node (its name) whose subscription a new '
              'agent\'s topic waits for.'),
    ParamSpec('match_timeout', 0.0, ParameterType.PARAMETER_DOUBLE,
              'Hold a new agent\'s first pose until match_node subscribes to its topic '
              '(an error node with agent_pattern finds it within about a second, and '
              'then gets every step), at most this many wall seconds, then 0.2 s more '
              'for the node\'s new fix publisher to meet its subscribers; 0: do not wait.',
              low=0.0, high=600.0),
)


def datum_frame(datum: Sequence[float] | None, input_type: str,
                why: str | None = None) -> LocalTangentFrame:
    """
    Return the :class:`LocalTangentFrame` of the ``datum`` parameter.

    Parameters
    ----------
    datum
        ``[lat_deg, lon_deg]`` or ``[lat_deg, lon_deg, alt_m]``.
    input_type
        The node's ``input_type`` (for the message when ``datum`` is missing).
    why
        What needs the datum, for that message (default: the ``input_type``).

    Returns
    -------
    LocalTangentFrame
        The map frame.

    Raises
    ------
    ConfigError
        When it is missing (pose and odometry input need it), has the wrong
        length, or lies outside valid latitude/longitude.

    """
    if not datum:
        raise ConfigError(
            f'parameter \'datum\' is required for {why or f"input_type {input_type!r}"}: '
            f'expected [lat_deg, lon_deg, alt_m] of the map frame origin')
    if len(datum) not in (2, 3):
        raise ConfigError(f'parameter \'datum\': invalid value {datum!r}: '
                          f'expected [lat_deg, lon_deg] or [lat_deg, lon_deg, alt_m]')
    try:
        return LocalTangentFrame(*datum)
    except GeodesyError as exc:
        raise ConfigError(f'parameter \'datum\': invalid value {datum!r}: '
                          f'{exc}') from None
