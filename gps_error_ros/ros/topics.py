"""
Every topic and service the nodes use, with its type and QoS: one table.

The nodes create their endpoints with the QoS profiles defined here; their
``--help`` and the README's topic tables (``tools/readme_parameters.py``)
are rendered from :data:`NODE_TOPICS`, and a test compares the table with
what a running node shows in the ROS graph.
"""

from dataclasses import dataclass

from rclpy.qos import (DurabilityPolicy, HistoryPolicy, QoSProfile,
                       ReliabilityPolicy)

# Sensor-data QoS (best effort, volatile) with a deeper history than the
# stock profile's 5, so a burst of truth messages is buffered, not dropped.
# Reliable on request (parameter input_reliability): lost messages are
# re-sent, and a publisher that waits for acknowledgements before it goes
# (gps_error_sumo, as a person leaves) can know its last poses arrived; best
# effort sends none, and a departing person's last poses were lost on a
# loaded machine (no fix for their steps).
TRUTH_QOS = {
    name: QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=policy)
    for name, policy in (('best_effort', ReliabilityPolicy.BEST_EFFORT),
                         ('reliable', ReliabilityPolicy.RELIABLE))}
# Reliable (the default), with a history long enough that a fix lost in a
# burst can still be repaired (Fast DDS re-sends after ~3 s; a crowd run
# faster than real time publishes many steps in that time, and depth 10 let 16
# of 3.6 M fixes go). Best effort on request (parameter fix_reliability).
FIX_QOS = {
    name: QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=policy)
    for name, policy in (('reliable', ReliabilityPolicy.RELIABLE),
                         ('best_effort', ReliabilityPolicy.BEST_EFFORT))}
# A deep history: a recording replayed fast must not overwrite what is not yet
# read. Best effort by default, so sensor drivers' best-effort publishers
# match; reliable on request (parameter input_reliability), so that a replayed
# recording loses nothing in transport (best effort drops a message now and
# then on a loaded machine, and a fit from live topics then differs from the
# offline fit of the same bag).
CALIBRATION_INPUT_QOS = {
    name: QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5000, reliability=policy)
    for name, policy in (('best_effort', ReliabilityPolicy.BEST_EFFORT),
                         ('reliable', ReliabilityPolicy.RELIABLE))}
# As diagnostic_updater: reliable, volatile, a short history (a monitor wants
# the newest status, not a backlog).
DIAGNOSTICS_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                             reliability=ReliabilityPolicy.RELIABLE)
DIAGNOSTICS_TOPIC = '/diagnostics'
# gps_error_sumo's truth: reliable (so a recorder may ask for every message;
# the error node's best-effort subscriptions match it too), keep last 100.
SUMO_TRUTH_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                            reliability=ReliabilityPolicy.RELIABLE)
# /clock as simulators publish it (reliable, keep last 10); rclpy's time
# source subscribes best effort, which matches.
CLOCK_PUB_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                           reliability=ReliabilityPolicy.RELIABLE)


def qos_text(qos: QoSProfile | None) -> str:
    """Return a QoS profile as the README writes it (``best effort, keep last 100``)."""
    if qos is None:
        return 'rcl default'
    parts = [{ReliabilityPolicy.RELIABLE: 'reliable',
              ReliabilityPolicy.BEST_EFFORT: 'best effort'}[qos.reliability]]
    if qos.durability == DurabilityPolicy.TRANSIENT_LOCAL:
        parts.append('transient local')
    if qos.history == HistoryPolicy.KEEP_LAST:
        parts.append(f'keep last {qos.depth}')
    return ', '.join(parts)


@dataclass(frozen=True)
class Endpoint:
    """One topic or service of a node."""

    direction: str      # 'in', 'out' or 'srv'
    name: str
    type: str           # package/Type
    qos: QoSProfile | dict[str, QoSProfile] | None
    note: str

    def qos_cell(self) -> str:
        """Return the QoS as table text (each choice named for a parameter)."""
        if isinstance(self.qos, dict):
            choices = list(self.qos.values())
            first = choices[0]
            if all(q.depth == first.depth and q.durability == first.durability
                   and q.history == first.history for q in choices):
                # they differ in reliability alone: name it once, the default first
                kinds = [qos_text(q).split(', ')[0] for q in choices]
                rest = ', '.join(qos_text(first).split(', ')[1:])
                return ' or '.join([f'{kinds[0]} (default)'] + kinds[1:]) + f', {rest}'
            return '; '.join(f'{qos_text(q)} ({k})' for k, q in self.qos.items())
        return qos_text(self.qos)


_DIAGNOSTICS = Endpoint('out', DIAGNOSTICS_TOPIC, 'diagnostic_msgs/DiagnosticArray',
                        DIAGNOSTICS_QOS, 'status at 1 Hz of wall time')
# rclpy's time source subscribes to /clock itself, with this QoS (Jazzy).
CLOCK_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
_CLOCK = Endpoint('in', '/clock', 'rosgraph_msgs/Clock', CLOCK_QOS,
                  'with use_sim_time:=true (rclpy\'s own subscription)')

_RCL = Endpoint('out', '/rosout, /parameter_events', 'rcl_interfaces/Log, ParameterEvent',
                None, 'every node\'s own (logging, parameter changes); also the '
                'parameter services ~/get_parameters etc.')

#: node -> its endpoints, in the order --help and the README list them
NODE_TOPICS = {
    'gps_error_node': (
        Endpoint('in', 'pose', 'geometry_msgs/PoseStamped', TRUTH_QOS,
                 'truth, input_type pose (QoS by input_reliability)'),
        Endpoint('in', 'odom', 'nav_msgs/Odometry', TRUTH_QOS, 'truth, input_type odometry'),
        Endpoint('in', 'fix_truth', 'sensor_msgs/NavSatFix', TRUTH_QOS,
                 'truth, input_type navsatfix'),
        Endpoint('out', 'fix', 'sensor_msgs/NavSatFix', FIX_QOS,
                 'one per step of rate (QoS by fix_reliability)'),
        Endpoint('out', 'vel', 'geometry_msgs/TwistWithCovarianceStamped', FIX_QOS,
                 'reported velocity, ENU, with each fix, when the profile has velocity'),
        Endpoint('out', 'fix_pose', 'geometry_msgs/PoseWithCovarianceStamped', FIX_QOS,
                 'each fix in the map frame (ENU about datum), with pose_frame_id'),
        Endpoint('in', 'A/pose', '(as pose)', TRUTH_QOS,
                 'per agent A with agents:=[...] or agent_pattern (A/odom, A/fix_truth '
                 'likewise)'),
        Endpoint('out', 'A/fix', 'sensor_msgs/NavSatFix', FIX_QOS, 'per agent A'),
        Endpoint('out', 'A/vel', 'geometry_msgs/TwistWithCovarianceStamped', FIX_QOS,
                 'per agent A, when its profile has velocity'),
        Endpoint('out', 'A/fix_pose', 'geometry_msgs/PoseWithCovarianceStamped', FIX_QOS,
                 'per agent A, with pose_frame_id'),
        _DIAGNOSTICS,
        _CLOCK,
        _RCL,
    ),
    'gps_calibration_node': (
        Endpoint('in', 'fix', 'sensor_msgs/NavSatFix', CALIBRATION_INPUT_QOS,
                 'the measured fixes (QoS by input_reliability)'),
        Endpoint('in', 'pose', 'geometry_msgs/PoseStamped', CALIBRATION_INPUT_QOS,
                 'truth, input_type pose'),
        Endpoint('in', 'odom', 'nav_msgs/Odometry', CALIBRATION_INPUT_QOS,
                 'truth, input_type odometry'),
        Endpoint('in', 'fix_truth', 'sensor_msgs/NavSatFix', CALIBRATION_INPUT_QOS,
                 'truth, input_type navsatfix'),
        Endpoint('srv', '~/calibrate', 'std_srvs/Trigger', None, 'fit and write now'),
        _DIAGNOSTICS,
        _CLOCK,
        _RCL,
    ),
    'gps_error_sumo': (
        Endpoint('out', '/clock', 'rosgraph_msgs/Clock', CLOCK_PUB_QOS,
                 'SUMO\'s time, once per SUMO step, after that step\'s truth'),
        Endpoint('out', 'PREFIX/P/pose', 'geometry_msgs/PoseStamped', SUMO_TRUTH_QOS,
                 'per person P (vehicle V with vehicle_prefix), output_type pose; '
                 'created when it appears in SUMO, destroyed when it leaves'),
        Endpoint('out', 'PREFIX/P/fix_truth', 'sensor_msgs/NavSatFix', SUMO_TRUTH_QOS,
                 'likewise, output_type navsatfix'),
        _RCL,
    ),
}


def markdown_topics(node: str) -> str:
    """Return the README's Markdown table of ``node``'s topics and services."""
    lines = ['| direction | topic | type | QoS | note |', '|---|---|---|---|---|']
    for e in NODE_TOPICS[node]:
        lines.append(f'| {e.direction} | `{e.name}` | {e.type} | {e.qos_cell()} | {e.note} |')
    return '\n'.join(lines) + '\n'


def help_rows(node: str) -> list[tuple[str, str, str, str]]:
    """Return (direction, topic, type, note) rows for ``--help``."""
    return [(e.direction, e.name, e.type, e.note) for e in NODE_TOPICS[node]]
