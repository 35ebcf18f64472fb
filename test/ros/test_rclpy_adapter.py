"""
What the crowd's fast path takes from rclpy below its public API, checked on the installed rclpy.

``gps_error_ros.ros.rclpy_adapter`` is the one place the nodes reach past
rclpy's public API (decision 0030). Each test here holds one thing it relies
on, in one process with a real context on loopback: a change in rclpy
fails here, by name, rather than as lost messages or a slow crowd.
"""

from importlib import metadata
import time

from geometry_msgs.msg import PoseStamped
import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.serialization import deserialize_message, serialize_message

from gps_error_ros.ros.rclpy_adapter import (DrainedByTheNode, handles, publish_raw,
                                             RCLPY_TESTED, take_message, take_raw,
                                             WaitsOnUndrained)

TOPIC = 'adapter_check'


class _Crowd(WaitsOnUndrained, Node):
    """A node with one drained subscription and one an executor runs."""


@pytest.fixture
def crowd():
    """Yield a :class:`_Crowd` in a context of its own; shut down after."""
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = _Crowd(f'adapter_check_{time.monotonic_ns()}', context=ctx)
    node.drained = DrainedByTheNode()
    node.heard = []
    node.quiet = node.create_subscription(PoseStamped, TOPIC, node.heard.append, 10,
                                          callback_group=node.drained, raw=True)
    node.loud = node.create_subscription(PoseStamped, TOPIC + '_loud', node.heard.append, 10)
    node.pub = node.create_publisher(PoseStamped, TOPIC, 10)
    node.loud_pub = node.create_publisher(PoseStamped, TOPIC + '_loud', 10)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    yield node, executor
    executor.shutdown()
    node.destroy_node()
    rclpy.shutdown(context=ctx)


def _pose(x):
    msg = PoseStamped()
    msg.pose.position.x = float(x)
    return msg


def _wait(cond, executor, seconds=10.0):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if cond():
            return True
        executor.spin_once(timeout_sec=0.05)
    return cond()


def test_the_installed_rclpy_is_the_one_the_adapter_was_tested_with():
    # a newer rclpy may keep every behaviour below; the tests below say which broke
    assert metadata.version('ros-jazzy-rclpy') == RCLPY_TESTED


def test_executors_wait_only_on_the_undrained_and_the_node_takes_the_rest(crowd):
    node, executor = crowd
    assert list(node.subscriptions) == [node.loud]
    assert node.quiet in node._subscriptions          # destroy_node still destroys it
    for k in range(3):
        node.pub.publish(_pose(k))
    node.loud_pub.publish(_pose(9))
    assert _wait(lambda: node.heard, executor)
    # the executor ran the undrained callback only; the drained messages wait
    assert [m.pose.position.x for m in node.heard] == [9.0]
    got = []

    def take_all():
        got.extend(iter(lambda: take_raw(*handles(node.quiet)), None))
        return len(got) == 3
    assert _wait(take_all, executor)
    assert [deserialize_message(r, PoseStamped).pose.position.x for r in got] == [0, 1, 2]
    assert take_raw(*handles(node.quiet)) is None


def test_a_drained_group_never_runs_its_members():
    group = DrainedByTheNode()
    assert group.can_execute(object()) is False
    assert group.beginning_execution(object()) is False
    # rclpy's executors call these three on a callback group: the interface still has them
    for name in ('can_execute', 'beginning_execution', 'ending_execution'):
        assert callable(getattr(rclpy.callback_groups.CallbackGroup, name))


def test_raw_bytes_published_on_a_handle_arrive_as_the_message(crowd):
    node, executor = crowd
    publish_raw(node.pub.handle, serialize_message(_pose(4.5)))
    got = []
    assert _wait(lambda: (got.append(take_message(node.quiet)) or got[-1] is not None),
                 executor)
    assert deserialize_message(got[-1], PoseStamped).pose.position.x == 4.5
    assert take_message(node.quiet) is None
