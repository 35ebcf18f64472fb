"""ROS 2 layer: parameter tables, message conversions and the nodes."""
