"""Test configuration: DDS on loopback in a per-run domain, shared fixtures."""

import os
import random
import sys

import pytest

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 100)))
os.environ.pop('ROS_LOCALHOST_ONLY', None)


def worker_domain(base, worker):
    """
    Return the ROS domain of a pytest-xdist worker (``gw0``, ``gw1``, ...) in a run.

    Each worker gets a domain of its own next to the run's (1..100, wrapping),
    so the nodes of two workers never meet; without xdist the run's own.
    """
    if not worker or not worker.startswith('gw'):
        return base
    return 1 + (base - 1 + int(worker[2:])) % 100


os.environ['ROS_DOMAIN_ID'] = str(worker_domain(int(os.environ['ROS_DOMAIN_ID']),
                                                os.environ.get('PYTEST_XDIST_WORKER')))


@pytest.fixture(autouse=True)
def _no_leftover_nodes():
    """Kill node processes a failing test left behind (after each test)."""
    yield
    harness = sys.modules.get('ros_harness')
    if harness is not None:
        harness.stop_all()
