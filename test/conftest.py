"""Test configuration: DDS on loopback in a per-run domain, shared fixtures."""

import os
import random
import sys

import pytest

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 100)))
os.environ.pop('ROS_LOCALHOST_ONLY', None)


@pytest.fixture(autouse=True)
def _no_leftover_nodes():
    """Kill node processes a failing test left behind (after each test)."""
    yield
    harness = sys.modules.get('ros_harness')
    if harness is not None:
        harness.stop_all()
