// The teamcomm process's bus side: ROBOT_STATE, BALL_STATE and VISION_OBSTACLES in; the team packet
// out over a PacketLink at the send rate with what is fresh; teammates' packets in (decoded,
// authenticated, gated, their round trips fed to the clock offset estimators, their estimates
// converted to our clock); TEAM_STATE out at the publish rate. Refused packets are counted by
// reason (SERVICE_STATUS errors "rejected_<reason>", TEAM_STATE.packets_rejected per claimed
// sender).
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/bus/node.hpp"
#include "common/perception/estimates.hpp"
#include "teamcomm/clock_offset.hpp"
#include "teamcomm/packet.hpp"
#include "teamcomm/packet_gate.hpp"
#include "teamcomm/team_picture.hpp"
#include "teamcomm/transport.hpp"

namespace fieldline::teamcomm {

struct TeamcommOptions {
  std::uint8_t team_id = 1;
  TeamKey key;
  // Team packets per second (10..30) at least, and at most: a new ball estimate (BALL_STATE, valid
  // or just become invalid) goes out at once when the last packet is at least 1/max_send_rate_hz
  // old, so teammates' balls are not a send period older than they need be (a kicked ball moves
  // 15 cm in 50 ms, and a ball put back elsewhere must leave the team ball at once).
  double send_rate_hz = 20.0;
  double max_send_rate_hz = 30.0;
  // TEAM_STATE per second.
  double publish_rate_hz = 10.0;
  // How often the link is read, µs (until the bus waits on the socket itself).
  Utime poll_period_us = 2'000;
  // Our own estimates older than this (since they arrived) are not sent.
  Utime fresh_us = 300'000;
  // Our own packets come back (multicast loopback): ignore fresh ones. Otherwise any packet
  // with our robot id is a replay.
  bool expect_own_echo = true;
  // A teammate whose every packet was refused as stale for this long, with no round trip to say
  // why, has its clock offset forgotten: its packets are then judged as before the first round
  // trip (gate.max_clock_difference_us) while new round trips re-seed the offset, µs.
  Utime offset_reset_after_stale_us = 2'000'000;
  GateOptions gate;
  OffsetOptions offset;
  PictureOptions picture;
};

// Counts kept by the node, for tests and the status.
struct LinkCounters {
  std::int64_t sent = 0;
  std::int64_t send_failures = 0;
  std::int64_t accepted = 0;
  std::int64_t own_echo = 0;
  std::array<std::int64_t, kRejectKinds> rejected{};
  // Teammates' clock steps confirmed by round trips, offsets forgotten after refusing a
  // teammate as stale for too long, and sequence restarts accepted (a restart on a clock set
  // back).
  std::int64_t clock_steps = 0;
  std::int64_t offset_resets = 0;
  std::int64_t sequence_restarts = 0;
  std::int64_t rejectedTotal() const;
};

// The channels the team link reads and writes on its robot's bus (fieldline-teamcomm --print-io
// adds the team network its main opens).
bus::ProcessIo teamcommIo();

class TeamcommNode {
 public:
  // Subscribes ROBOT_STATE, BALL_STATE and VISION_OBSTACLES on `node`'s bus and starts the send,
  // poll and publish timers. `link` must outlive the node.
  TeamcommNode(bus::Node& node, PacketLink& link, TeamcommOptions options);

  const LinkCounters& counters() const { return counters_; }
  // The offset estimate of a teammate's clock (theirs minus ours) at `now`.
  std::optional<OffsetEstimate> offset(int robot_id, Utime now) const;
  // Reads the link now (before each packet sent and each TEAM_STATE, or every poll period for a
  // link without a socket).
  void pollLink();
  // Whether the event loop waits on the link's socket (through a flood and 2 s after it).
  bool waitsOnLink() const;
  // Datagrams in one read that make it a flood, and how long the socket is then waited on.
  static constexpr int kFloodDatagramsPerRead = 32;
  static constexpr Utime kWatchAfterFlood_us = 2'000'000;

 private:
  struct Teammate {
    ClockOffsetEstimator offset;
    // The newest accepted packet: its send time (their clock) and arrival (ours).
    Utime last_send_utime = 0;
    Utime last_receive_utime = 0;
    bool heard = false;
    std::int32_t received = 0;
    std::int32_t rejected = 0;
    // Since when (our clock) every packet of it was refused as stale (-1: its last was
    // accepted), and by how much the last one missed, µs (positive: sent in our future).
    Utime stale_since = -1;
    double stale_by_us = 0.0;
    // Our clock at its last authenticated packet, accepted or not.
    Utime last_authenticated = -1;
    // The gate's sequence restarts of it already reported.
    std::int64_t sequence_restarts = 0;
  };

  // Sends when the last packet is a send period old, or when `new_ball` and it is at least the
  // shortest interval old (steady clock: a step of the clock stalls nothing).
  void maybeSend(bool new_ball);
  // The send timer: a one-shot set for when the next packet is due and set again each time, so
  // an idle link sleeps between packets instead of checking every few ms (issue 32).
  void onSendTimer();
  Utime sendPeriod() const;
  void sendPacket();
  // A datagram from the team network: decoded and authenticated, then our own echo, or a
  // teammate's packet through the gate into the picture; refusals counted by reason.
  void onDatagram(std::span<const std::uint8_t> bytes, Utime age_us);
  // Our own packet back: the multicast loopback echo, or a replay of it.
  void onOwnPacket(const TeamPacket& p, Utime received);
  // The gate's verdict, judged again after a clock step its round trips confirm or after its
  // offset is forgotten (every packet refused as stale for too long).
  std::optional<Reject> admitTeammatePacket(const TeamPacket& p, Teammate& mate,
                                            const std::optional<RoundTrip>& trip, Utime received);
  // Feeds a round trip of a packet refused as stale; true when it confirms a clock step.
  bool learnClockStep(const TeamPacket& p, Teammate& mate, const RoundTrip& trip);
  // Forgets the offset of a teammate refused as stale for too long; true when it did.
  bool forgetStaleOffset(const TeamPacket& p, Teammate& mate, Utime received);
  // Counts a refused packet; one refused as stale says since when and by how much (and is still
  // echoed when new, so the round trips can show a clock step).
  void refuseTeammatePacket(const TeamPacket& p, Teammate& mate, Reject reason, Utime received);
  // Counts an admitted packet and learns from it (round trip, sequence restart, last heard).
  void acceptTeammatePacket(const TeamPacket& p, Teammate& mate,
                            const std::optional<RoundTrip>& trip, Utime received);
  // What an admitted packet says, on our clock (its last pose when it sent none).
  Report teammateReport(const TeamPacket& p, const Teammate& mate, Utime received) const;
  void reject(Reject reason, int claimed_robot, const std::string& detail);
  // The round trip a packet's echo of our own packet makes, when the echo names one of our
  // recent packets (which also proves the packet was made after it).
  std::optional<RoundTrip> echoedRoundTrip(const TeamPacket& p, Utime received) const;
  // What the status says about teammates' clocks (stale refusals, steps re-converging).
  void updateClockWarnings(Utime now);
  // The kernel's drops on the team socket: a metric, and a warning while they grow.
  void updateKernelDrops(Utime now);
  void publishTeamState();
  // A teammate's time on our clock: through its offset when known, else relative to its send
  // time (which ignores the network delay).
  Utime toOurClock(const Teammate& mate, Utime their_utime, Utime their_send_utime,
                   Utime our_receive_utime) const;

  bus::Node& node_;
  PacketLink& link_;
  TeamcommOptions options_;
  PacketGate gate_;
  TeamPicture picture_;
  std::array<Teammate, kMaxRobots> mates_;
  std::optional<perception::RobotEstimate> own_robot_;
  Utime own_robot_received_ = 0;
  std::optional<perception::BallEstimate> own_ball_;
  Utime own_ball_received_ = 0;
  // The obstacles of the newest VISION_OBSTACLES frame, in the field frame.
  std::vector<PacketObstacle> own_obstacles_;
  Utime own_obstacles_received_ = 0;
  std::uint64_t next_sequence_ = 0;
  // Steady time of the last packet sent (-1: none yet).
  Utime last_send_steady_ = -1;
  // Send times (our clock) of our recent packets, oldest first: what a teammate's echo must name.
  std::deque<Utime> recent_sends_;
  // (our clock, the link's kernel drop total) over the last seconds.
  std::deque<std::pair<Utime, std::int64_t>> kernel_drops_;
  LinkCounters counters_;
  team_state_t team_state_msg_{};
  // The link's socket (-1: none), the watch on it while a flood lasts, and until when (steady).
  int link_fd_ = -1;
  std::optional<bus::Node::WatchId> link_watch_;
  Utime watch_link_until_ = 0;
};

}  // namespace fieldline::teamcomm
