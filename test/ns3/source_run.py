"""
Run :class:`~gps_error_ros.ns3.source.GpsSource` in ns-3 and save what it gave (a test's helper).

Six nodes: four follow waypoints that turn corners and stand (ns-3's
``WaypointMobilityModel``), two follow an ns-2 mobility trace
(``Ns2MobilityHelper``). Usage: ``source_run.py PROFILE|none SEED SECONDS OUT.npz``;
with ``--fcd FCD.xml`` before them, one node per agent of a SUMO FCD file
(lon/lat) instead, its errors started at the file's first time, and with
``--faults SCHEDULE.yaml`` too, those faults laid over its fixes;
``--covariance-mode MODE``: the stated accuracy's, as ``simulate``'s.
A process of its own: ns-3 takes some 15 s to import and has one simulator.
"""

import sys
from pathlib import Path

import numpy as np

NS2 = '''$node_(4) set X_ 5.0
$node_(4) set Y_ -3.0
$node_(4) set Z_ 0.0
$node_(5) set X_ -20.0
$node_(5) set Y_ 40.0
$node_(5) set Z_ 0.0
$ns_ at 2.0 "$node_(4) setdest 40.0 -3.0 1.4"
$ns_ at 35.0 "$node_(4) setdest 40.0 30.0 1.2"
$ns_ at 0.0 "$node_(5) setdest 60.0 40.0 9.0"
'''
WAYPOINTS = [
    [(0.0, 0.0, 0.0), (20.0, 0.0, 28.0), (26.0, 0.0, 28.0), (50.0, 30.0, 28.0)],
    [(0.0, 10.0, 10.0), (15.0, 30.0, 10.0), (40.0, 30.0, -20.0)],
    [(0.0, -50.0, 5.0), (8.0, -50.0, 5.0), (30.0, -20.0, 5.0), (45.0, -20.0, 25.0)],
    [(0.0, 3.0, 3.0), (60.0, 3.0, 3.0)],
]


def main() -> None:
    """Run the nodes for SECONDS; save the source's epochs and the agents' names."""
    args = sys.argv[1:]
    fcd = faults = None
    mode = 'stationary'
    while args[0] in ('--fcd', '--faults', '--covariance-mode'):
        if args[0] == '--fcd':
            fcd = args[1]
        elif args[0] == '--faults':
            faults = args[1]
        else:
            mode = args[1]
        args = args[2:]
    spec, seed, seconds, out = args[0], int(args[1]), float(args[2]), args[3]
    from ns import ns
    import gps_error_ros as ge
    from gps_error_ros.ns3.source import GpsSource
    profile = None if spec == 'none' else ge.load_profile(spec)
    if fcd is not None:
        from gps_error_ros.ns3.fcd import fcd_tracks
        from gps_error_ros.ns3.tracks import waypoint_nodes
        tracks, first = fcd_tracks(fcd, 'lonlat')
        from gps_error_ros.sim.faults import load_schedule
        source = GpsSource(waypoint_nodes(tracks), profile, seed, names=tracks.names,
                           keep=True, start=first,
                           faults=load_schedule(faults) if faults else ())
        source.run(seconds)
        assert source.epochs is not None
        np.savez(out, names=np.array(tracks.names), **source.epochs.arrays())
        ns.Simulator.Destroy()
        return
    walkers = ns.NodeContainer()
    walkers.Create(len(WAYPOINTS))
    helper = ns.MobilityHelper()
    helper.SetMobilityModel('ns3::WaypointMobilityModel')
    helper.Install(walkers)
    for i, points in enumerate(WAYPOINTS):
        m = walkers.Get(i).GetObject[ns.WaypointMobilityModel]()
        for t, x, y in points:
            m.AddWaypoint(ns.Waypoint(ns.Seconds(t), ns.Vector(x, y, 0.0)))
    traced = ns.NodeContainer()
    traced.Create(2)
    trace = Path(out).with_suffix('.ns2')
    trace.write_text(NS2)
    ns.Ns2MobilityHelper(str(trace)).Install()
    nodes = ns.NodeContainer(walkers, traced)
    names = ['ann', 'bob', 'cy', 'dee', 'ns2-eve', 'ns2-fay']
    source = GpsSource(nodes, profile, seed, names=names, keep=True, covariance_mode=mode)
    source.run(seconds)
    assert source.epochs is not None
    np.savez(out, names=np.array(names), **source.epochs.arrays())
    ns.Simulator.Destroy()


if __name__ == '__main__':
    main()
