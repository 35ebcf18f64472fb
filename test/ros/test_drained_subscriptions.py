"""A crowd's truth subscriptions are drained by the node, not waited on by executors."""

import json

import rclpy
from rclpy.context import Context


def test_executors_wait_only_on_the_nodes_own_subscriptions():
    from gps_error_ros.ros.error_node import GpsErrorNode
    context = Context()
    rclpy.init(context=context)
    names = json.dumps([f'a{i}' for i in range(50)])
    node = GpsErrorNode(context=context, cli_args=[
        '--ros-args', '-r', '__ns:=/drained_probe', '-p', 'input_type:=navsatfix',
        '-p', f'agents:={names}', '-p', 'profile:=DS5', '-p', 'use_sim_time:=true'])
    try:
        assert node.polled and len([s for s in node.subs if s is not None]) == 50
        waited = list(node.subscriptions)
        assert [s.topic_name for s in waited] == ['/clock']    # use_sim_time's, not a truth's
        assert all(s.callback_group is node.drained for s in node.subs)
        # destroying one through rclpy keeps the list of what executors wait on
        assert node.destroy_subscription(node.subs[0])
        assert [s.topic_name for s in node.subscriptions] == ['/clock']
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)
