"""
Smartphone GPS errors inside ns-3 (the optional extra ``ns3``).

:mod:`~gps_error_ros.ns3.source` gives every ns-3 node the fix its phone
would make; :mod:`~gps_error_ros.ns3.p2v` is a pedestrian-to-vehicle study
at a crossing that uses it. Only this wing imports ns-3 (``from ns import ns``,
which takes some 15 s), and only when it runs.
"""
