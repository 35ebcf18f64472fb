"""Fixtures of the integration tests: rclpy in the test process, a peer node."""

import pytest
import rclpy

from ros_harness import Peer


@pytest.fixture(scope='module', autouse=True)
def ros():
    rclpy.init()
    yield
    rclpy.try_shutdown()


@pytest.fixture
def peer():
    p = Peer()
    yield p
    p.destroy()
