// The C++ side of gps_error_ros's ns-3 path (gps_error_ros/ns3/native.py says what
// is here and why). Compiled by cling, through ns-3's Python bindings, on first use.
#include "ns3/core-module.h"
#include "ns3/network-module.h"
#include "ns3/internet-module.h"
#include "ns3/mobility-module.h"
#include "ns3/wifi-module.h"
#include <cstring>
#include <vector>

namespace gps_error_ns3 {
using namespace ns3;
const int kFields = 12;  // native.FIELDS

struct Gps {
  static std::vector<double>& Table() { static std::vector<double> t; return t; }
  static void Set(uint32_t n, const double* values) {
    Table().assign(values, values + size_t(n) * kFields);
  }
  static const double* Row(uint32_t node) {
    static const double none[kFields] = {0};
    auto& t = Table();
    return (size_t(node + 1) * kFields <= t.size()) ? &t[size_t(node) * kFields] : none;
  }
  static bool HasFix(uint32_t node) { return Row(node)[0] != 0.0; }
  static Vector Position(uint32_t node) {
    const double* r = Row(node);
    return Vector(r[4], r[5], 0.0);
  }
  static double Accuracy(uint32_t node) { return Row(node)[6]; }
};

// True positions and velocities (x, y, vx, vy) of nodes, for the source.
void TrueStates(NodeContainer nodes, double* out) {
  for (uint32_t i = 0; i < nodes.GetN(); ++i) {
    Ptr<MobilityModel> m = nodes.Get(i)->GetObject<MobilityModel>();
    Vector p = m->GetPosition(), v = m->GetVelocity();
    out[4 * i] = p.x; out[4 * i + 1] = p.y; out[4 * i + 2] = v.x; out[4 * i + 3] = v.y;
  }
}

#pragma pack(push, 1)
struct PsmContent {             // what SAE J2945/9's PSM states, not its encoding
  uint32_t id; uint32_t count; double t_fix; double lat; double lon;
  float accuracy_major; float accuracy_minor; float accuracy_orientation;
  float speed; float heading;
};
#pragma pack(pop)

struct Log {
  // messages sent: sender node, count, time, and the content's x/y in the local frame
  std::vector<uint32_t> tx_node, tx_count;
  std::vector<double> tx_time, tx_fix_time, tx_x, tx_y, tx_speed, tx_heading, tx_accuracy;
  // messages received: receiver node, sender node, count, time
  std::vector<uint32_t> rx_node, rx_from, rx_count;
  std::vector<double> rx_time;
  uint64_t no_fix = 0;
  // radio time not idle, per listed node (channel load)
  std::vector<double> busy;
  void Clear() { *this = Log(); }
};
Log& TheLog() { static Log log; return log; }

template <typename T> void Copy(const std::vector<T>& v, T* out) {
  if (!v.empty()) std::memcpy(out, v.data(), v.size() * sizeof(T));
}
void CopyU32(const std::vector<uint32_t>& v, uint32_t* out) { Copy(v, out); }
void CopyF64(const std::vector<double>& v, double* out) { Copy(v, out); }

void OnReceive(Ptr<Socket> socket) {
  Ptr<Packet> packet; Address from;
  Log& log = TheLog();
  while ((packet = socket->RecvFrom(from))) {
    if (packet->GetSize() < sizeof(PsmContent)) continue;
    PsmContent c; packet->CopyData(reinterpret_cast<uint8_t*>(&c), sizeof(c));
    log.rx_node.push_back(socket->GetNode()->GetId());
    log.rx_from.push_back(c.id); log.rx_count.push_back(c.count);
    log.rx_time.push_back(Simulator::Now().GetSeconds());
  }
}

void SendPsm(Ptr<Socket> socket, uint32_t count, double interval, uint32_t size, double stop) {
  double now = Simulator::Now().GetSeconds();
  if (now > stop) return;
  uint32_t id = socket->GetNode()->GetId();
  const double* r = Gps::Row(id);
  Log& log = TheLog();
  if (r[0] != 0.0) {
    PsmContent c{id, count, r[1], r[2], r[3], float(r[7]), float(r[8]), float(r[9]),
                 float(r[10]), float(r[11])};
    std::vector<uint8_t> bytes(std::max<size_t>(size, sizeof(c)), 0);
    std::memcpy(bytes.data(), &c, sizeof(c));
    socket->Send(Create<Packet>(bytes.data(), bytes.size()));
    log.tx_node.push_back(id); log.tx_count.push_back(count); log.tx_time.push_back(now);
    log.tx_fix_time.push_back(r[1]); log.tx_x.push_back(r[4]); log.tx_y.push_back(r[5]);
    log.tx_accuracy.push_back(r[6]); log.tx_speed.push_back(r[10]);
    log.tx_heading.push_back(r[11]);
  } else {
    log.no_fix++;
  }
  Simulator::Schedule(Seconds(interval), &SendPsm, socket, count + 1, interval, size, stop);
}

const uint16_t kPort = 4001;

// Senders broadcast PSMs from `offsets` (s) every `interval` s until `stop`.
void StartSenders(NodeContainer nodes, const double* offsets, double interval,
                  uint32_t size, double stop) {
  TypeId udp = TypeId::LookupByName("ns3::UdpSocketFactory");
  for (uint32_t i = 0; i < nodes.GetN(); ++i) {
    Ptr<Socket> s = Socket::CreateSocket(nodes.Get(i), udp);
    s->SetAllowBroadcast(true);
    s->Connect(InetSocketAddress(Ipv4Address("255.255.255.255"), kPort));
    Simulator::Schedule(Seconds(offsets[i]), &SendPsm, s, 0u, interval, size, stop);
  }
}

void StartReceivers(NodeContainer nodes) {
  TypeId udp = TypeId::LookupByName("ns3::UdpSocketFactory");
  for (uint32_t i = 0; i < nodes.GetN(); ++i) {
    Ptr<Socket> r = Socket::CreateSocket(nodes.Get(i), udp);
    r->Bind(InetSocketAddress(Ipv4Address::GetAny(), kPort));
    r->SetRecvCallback(MakeCallback(&OnReceive));
  }
}

void OnPhyState(uint32_t index, Time start, Time duration, WifiPhyState state) {
  if (state != WifiPhyState::IDLE && state != WifiPhyState::SLEEP && state != WifiPhyState::OFF)
    TheLog().busy[index] += duration.GetSeconds();
}

void TrackChannel(NodeContainer nodes) {
  Log& log = TheLog();
  log.busy.assign(nodes.GetN(), 0.0);
  for (uint32_t i = 0; i < nodes.GetN(); ++i) {
    std::string path = "/NodeList/" + std::to_string(nodes.Get(i)->GetId()) +
                       "/DeviceList/*/$ns3::WifiNetDevice/Phy/State/State";
    Config::ConnectWithoutContext(path, MakeBoundCallback(&OnPhyState, i));
  }
}
}  // namespace gps_error_ns3
