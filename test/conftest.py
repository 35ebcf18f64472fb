"""Test configuration: DDS on loopback in a per-run domain, shared fixtures."""

import os
import random

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 100)))
os.environ.pop('ROS_LOCALHOST_ONLY', None)
