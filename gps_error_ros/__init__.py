"""Smartphone GPS error model (Rostami et al.) for ROS 2 and simulators."""

__version__ = "0.1.0"
