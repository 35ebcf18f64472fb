"""
The study's ns-3 world: pedestrians' phones and vehicles on one 802.11p channel.

:func:`run_world` builds the nodes of a :class:`~gps_error_ros.ns3.crossing`
scenario, their waypoints and radios, starts the pedestrians' personal
safety messages and the vehicles' receivers, runs ns-3 with a
:class:`~gps_error_ros.ns3.source.GpsSource` updating the phones' fixes,
and returns what was sent and received. One world per process: ns-3 has
one simulator.

The radio: 802.11p (10 MHz at 5.9 GHz, 6 Mbit/s broadcasts), 20 dBm,
three-slope log-distance path loss with Nakagami fading, the set-up ns-3's
vehicular examples use; it is not calibrated here.
"""

from dataclasses import dataclass
import time
from typing import Any

import numpy as np

from gps_error_ros.model.profiles import Profile
from gps_error_ros.model.state import FloatArray
from gps_error_ros.ns3.native import cpp
from gps_error_ros.ns3.source import GpsSource
from gps_error_ros.ns3.tracks import Tracks, waypoint_nodes

#: The channel: frequency (Hz), the reference loss at 1 m for it (dB), transmit power (dBm).
FREQUENCY_HZ = 5.9e9
REFERENCE_LOSS_DB = 47.86
TX_POWER_DBM = 20.0


@dataclass(frozen=True)
class WorldSpec:
    """What one run simulates: the tracks, the messages and the phones' errors."""

    pedestrians: Tracks
    vehicles: Tracks
    duration: float
    rate_hz: float = 10.0
    size_bytes: int = 200
    seed: int = 1
    network_seed: int = 1


def _radios(ns: Any, everyone: Any) -> None:
    """Give every node an 802.11p radio on one channel, and an IPv4 address."""
    wifi = ns.WifiHelper()
    wifi.SetStandard(ns.WIFI_STANDARD_80211p)
    rate = ns.StringValue('OfdmRate6MbpsBW10MHz')
    wifi.SetRemoteStationManager('ns3::ConstantRateWifiManager', 'DataMode', rate,
                                 'ControlMode', rate)
    channel = ns.YansWifiChannelHelper()
    channel.SetPropagationDelay('ns3::ConstantSpeedPropagationDelayModel')
    channel.AddPropagationLoss('ns3::ThreeLogDistancePropagationLossModel',
                               'ReferenceLoss', ns.DoubleValue(REFERENCE_LOSS_DB))
    channel.AddPropagationLoss('ns3::NakagamiPropagationLossModel')
    phy = ns.YansWifiPhyHelper()
    phy.SetChannel(channel.Create())
    phy.Set('TxPowerStart', ns.DoubleValue(TX_POWER_DBM))
    phy.Set('TxPowerEnd', ns.DoubleValue(TX_POWER_DBM))
    mac = ns.WifiMacHelper()
    mac.SetType('ns3::AdhocWifiMac')
    devices = wifi.Install(phy, mac, everyone)
    wifi.AssignStreams(devices, 1000)
    ns.InternetStackHelper().Install(everyone)
    ip = ns.Ipv4AddressHelper()
    ip.SetBase(ns.Ipv4Address('10.1.0.0'), ns.Ipv4Mask('255.255.0.0'))
    ip.Assign(devices)


def run_world(spec: WorldSpec, profile: Profile | None) -> dict[str, Any]:
    """
    Run one world with the phones' ``profile`` (None: no errors); return its logs.

    Returns arrays: ``tx_*`` (one per message sent: sender index, count,
    time, the fix's time, its x/y, accuracy, speed and heading), ``rx_*``
    (one per message a vehicle received: vehicle index, sender index,
    count, time), ``busy`` (each vehicle's radio time not idle, s),
    ``no_fix`` (messages not sent for want of a fix) and ``wall_s`` (the
    run's wall time). Senders and vehicles are numbered by their index in
    the spec's tracks, not by ns-3's node ids.
    """
    from ns import ns
    native = cpp()
    native.TheLog().Clear()
    ns.RngSeedManager.SetSeed(1)
    ns.RngSeedManager.SetRun(spec.network_seed)
    peds, cars = waypoint_nodes(spec.pedestrians), waypoint_nodes(spec.vehicles)
    everyone = ns.NodeContainer(peds, cars)
    _radios(ns, everyone)
    rng = np.random.default_rng(spec.network_seed)
    interval = 1.0 / spec.rate_hz
    offsets = rng.uniform(0.0, interval, len(spec.pedestrians.names)) + 1e-4
    native.StartSenders(peds, offsets, interval, spec.size_bytes, spec.duration)
    native.StartReceivers(cars)
    native.TrackChannel(cars)
    source = GpsSource(peds, profile, spec.seed, names=spec.pedestrians.names)
    start = time.perf_counter()
    source.run(spec.duration)
    wall = time.perf_counter() - start
    out = _logs(native.TheLog())
    ped_ids = [peds.Get(i).GetId() for i in range(peds.GetN())]
    car_ids = [cars.Get(i).GetId() for i in range(cars.GetN())]
    out['tx_node'] = _index_of(out['tx_node'], ped_ids)
    out['rx_from'] = _index_of(out['rx_from'], ped_ids)
    out['rx_node'] = _index_of(out['rx_node'], car_ids)
    out['wall_s'] = wall
    ns.Simulator.Destroy()
    return out


def _index_of(ids: Any, node_ids: list[int]) -> Any:
    """Return each ns-3 node id of ``ids`` as its index in ``node_ids``."""
    lut = np.full(max(node_ids) + 1, -1, dtype=np.int64)
    lut[np.asarray(node_ids)] = np.arange(len(node_ids))
    return lut[np.asarray(ids, dtype=np.int64)]


def _logs(log: Any) -> dict[str, Any]:
    """Return the C++ log's vectors as numpy arrays (copied)."""
    native = cpp()
    out: dict[str, Any] = {}
    for name in ('tx_node', 'tx_count', 'rx_node', 'rx_from', 'rx_count'):
        vec = getattr(log, name)
        arr = np.zeros(vec.size(), dtype=np.uint32)
        native.CopyU32(vec, arr)
        out[name] = arr.astype(np.int64)
    for name in ('tx_time', 'tx_fix_time', 'tx_x', 'tx_y', 'tx_accuracy', 'tx_speed',
                 'tx_heading', 'rx_time', 'busy'):
        vec = getattr(log, name)
        f: FloatArray = np.zeros(vec.size())
        native.CopyF64(vec, f)
        out[name] = f
    out['no_fix'] = int(log.no_fix)
    return out
