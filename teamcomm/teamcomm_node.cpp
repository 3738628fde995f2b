#include "teamcomm/teamcomm_node.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

#include "common/msg/estimates.hpp"
#include "common/msg/obstacle_observations.hpp"
#include "common/msg/team_state.hpp"
#include "teamcomm/field_obstacles.hpp"

namespace fieldline::teamcomm {
namespace {

// Multicast loopback returns our packets within microseconds; allow for a busy machine.
constexpr Utime kOwnEchoMaxAge_us = 100'000;
// The first packet goes out this long after start (then a send period after the last one).
constexpr Utime kFirstSendDelay_us = 5'000;

float clampf(double v, double limit) {
  if (!std::isfinite(v)) return 0.0f;
  return static_cast<float>(std::clamp(v, -limit, limit));
}

// Our estimate in the packet's ranges (fusion's output is validated, but a pose far off the
// field or a runaway covariance must not stop the team link).
PacketPose toPacket(const perception::RobotEstimate& e) {
  PacketPose p;
  p.utime = std::max<Utime>(0, e.utime);
  p.x = clampf(e.pose.x, kMaxFieldCoordinate_m);
  p.y = clampf(e.pose.y, kMaxFieldCoordinate_m);
  p.phi = clampf(e.pose.phi, 3.14159f);
  p.vx = clampf(e.vx, kMaxSpeed_mps);
  p.vy = clampf(e.vy, kMaxSpeed_mps);
  p.omega = clampf(e.omega, kMaxAngularSpeed_radps);
  const auto& c = e.covariance;
  p.covariance = {static_cast<float>(std::clamp(c(0, 0), 0.0, kMaxVariance)),
                  clampf(c(0, 1), kMaxVariance),
                  clampf(c(0, 2), kMaxVariance),
                  static_cast<float>(std::clamp(c(1, 1), 0.0, kMaxVariance)),
                  clampf(c(1, 2), kMaxVariance),
                  static_cast<float>(std::clamp(c(2, 2), 0.0, kMaxVariance))};
  for (float& v : p.covariance) {
    if (!std::isfinite(v)) v = static_cast<float>(kMaxVariance);
  }
  p.status = static_cast<std::uint8_t>(std::clamp<int>(static_cast<int>(e.status), 0, 3));
  p.twin_ambiguous = e.twin_ambiguous;
  p.since_vision_us = std::max<std::int64_t>(0, e.since_vision_us);
  return p;
}

PacketBall toPacket(const perception::BallEstimate& e) {
  PacketBall b;
  b.utime = std::max<Utime>(0, e.utime);
  b.last_seen_utime = std::max<Utime>(0, e.last_seen_utime);
  b.x = clampf(e.x, kMaxFieldCoordinate_m);
  b.y = clampf(e.y, kMaxFieldCoordinate_m);
  b.vx = clampf(e.vx, kMaxSpeed_mps);
  b.vy = clampf(e.vy, kMaxSpeed_mps);
  const auto& c = e.covariance;
  b.covariance = {static_cast<float>(std::clamp(c(0, 0), 0.0, kMaxVariance)),
                  clampf(c(0, 1), kMaxVariance),
                  static_cast<float>(std::clamp(c(1, 1), 0.0, kMaxVariance))};
  for (float& v : b.covariance) {
    if (!std::isfinite(v)) v = static_cast<float>(kMaxVariance);
  }
  return b;
}

// A teammate's clock offset at `t`, µs (none before its first round trips).
std::optional<double> offsetAt(const ClockOffsetEstimator& offset, Utime t) {
  const auto e = offset.estimate(t);
  return e ? std::optional<double>(e->offset_us) : std::nullopt;
}

}  // namespace

std::int64_t LinkCounters::rejectedTotal() const {
  std::int64_t total = 0;
  for (std::int64_t n : rejected)
    total += n;
  return total;
}

TeamcommNode::TeamcommNode(bus::Node& node, PacketLink& link, TeamcommOptions options)
    : node_(node),
      link_(link),
      options_(std::move(options)),
      gate_([&] {
        GateOptions g = options_.gate;
        g.team_id = options_.team_id;
        return g;
      }()),
      picture_(node.robotId(), options_.picture) {
  if (options_.send_rate_hz < 1.0 || options_.send_rate_hz > 100.0 ||
      options_.max_send_rate_hz < options_.send_rate_hz || options_.max_send_rate_hz > 100.0 ||
      options_.publish_rate_hz < 1.0 || options_.publish_rate_hz > 100.0 ||
      options_.poll_period_us < 100) {
    throw std::invalid_argument("teamcomm: rates or poll period out of range");
  }
  for (Teammate& m : mates_)
    m.offset = ClockOffsetEstimator(options_.offset);
  // Grows across restarts (the clock moves on faster than we send), so receivers' replay checks
  // accept a restarted robot at once.
  next_sequence_ = static_cast<std::uint64_t>(std::max<Utime>(0, node_.now()));
  // The link counts its drops from its opening, about now.
  kernel_drops_.emplace_back(node_.now(), 0);
  // Our pose and obstacles are needed only when a packet goes out: they do not wake the link,
  // they are handled before its next timer or BALL_STATE (issue 32); the ball may send at once.
  node_.subscribeDeferred(bus::channels::kRobotState, [this](const robot_state_t& m) {
    own_robot_ = msg::fromMessage(m);
    own_robot_received_ = node_.now();
  });
  // Without its own pose the link sends teammates nothing useful: WARN "ROBOT_STATE silent"
  // (issue 34, red-team finding 5: a dead input must not look ok).
  node_.requireInput(
      bus::channels::kRobotState,
      bus::kRequiredRateFraction * bus::nominalRateHz(bus::channels::kRobotState.name));
  node_.subscribe(bus::channels::kBallState, [this](const ball_state_t& m) {
    const bool was_valid = own_ball_ && own_ball_->valid;
    own_ball_ = msg::fromMessage(m);
    own_ball_received_ = node_.now();
    // A ball seen, or one just lost (kicked away, put back: teammates must stop using it), goes
    // out at once.
    maybeSend(own_ball_->valid || was_valid);
  });
  // What the camera saw, placed on the field with the newest pose (obstacles without a pose
  // near the frame's time are not sent).
  node_.subscribeDeferred(
      bus::channels::kVisionObstacles, [this](const obstacle_observations_t& m) {
        if (!own_robot_) return;
        own_obstacles_ = obstaclesInField(msg::toObstacleSightings(m), *own_robot_);
        own_obstacles_received_ = node_.now();
      });
  // The first packet soon after start; from then on the timer is set for when the next is due.
  node_.after(kFirstSendDelay_us, [this] { onSendTimer(); });
  // A socket is read before each packet we send and each TEAM_STATE (pollLink), and waited on
  // only through a flood; a link without one (the in-process test hub) is polled.
  link_fd_ = link_.fileDescriptor();
  if (link_fd_ < 0) {
    node_.every(options_.poll_period_us, [this] { pollLink(); });
  }
  node_.every(static_cast<Utime>(1e6 / options_.publish_rate_hz), [this] { publishTeamState(); });
  node_.declareIo(teamcommIo());
}

bus::ProcessIo teamcommIo() {
  return bus::ProcessIo("teamcomm")
      .reads(bus::channels::kRobotState)
      .readsIfPresent(bus::channels::kBallState)
      .readsIfPresent(bus::channels::kVisionObstacles)
      .writes(bus::channels::kTeamState);
}

std::optional<OffsetEstimate> TeamcommNode::offset(int robot_id, Utime now) const {
  if (robot_id < 1 || robot_id > kMaxRobots || robot_id == node_.robotId()) return std::nullopt;
  return mates_[static_cast<std::size_t>(robot_id - 1)].offset.estimate(now);
}

Utime TeamcommNode::sendPeriod() const {
  return static_cast<Utime>(1e6 / options_.send_rate_hz);
}

void TeamcommNode::onSendTimer() {
  // Set again even when the send throws (the node counts the error): a one-shot that is not set
  // again would end the team link's sending for the rest of the run.
  struct SetAgain {
    TeamcommNode& self;
    ~SetAgain() {
      // Due a send period after the last packet. A ball sent in between makes that later: this
      // timer then wakes once for nothing and is set again, far fewer wake-ups than polling.
      const Utime steady = self.node_.clock().monotonicNow();
      const Utime due = self.last_send_steady_ < 0 ? steady + self.sendPeriod()
                                                   : self.last_send_steady_ + self.sendPeriod();
      self.node_.after(std::max<Utime>(0, due - steady), [&s = self] { s.onSendTimer(); });
    }
  } set_again{*this};
  maybeSend(false);
}

void TeamcommNode::maybeSend(bool new_ball) {
  const Utime steady = node_.clock().monotonicNow();
  const Utime since =
      last_send_steady_ < 0 ? std::numeric_limits<Utime>::max() : steady - last_send_steady_;
  const Utime period = sendPeriod();
  // Less a few ms: BALL_STATE comes at about the same rate, and its jitter must not make every
  // other one wait (at most 35 packets/s from 30 Hz; the receivers' gate allows 40).
  const Utime shortest = static_cast<Utime>(1e6 / options_.max_send_rate_hz) - 5'000;
  if (since < shortest || (since < period && !new_ball)) return;
  last_send_steady_ = steady;
  sendPacket();
}

void TeamcommNode::sendPacket() {
  // What teammates sent since the last read: the echoes below name their newest packets.
  if (link_fd_ >= 0) pollLink();
  const Utime now = node_.now();
  TeamPacket p;
  p.team_id = options_.team_id;
  p.robot_id = static_cast<std::uint8_t>(node_.robotId());
  p.sequence = next_sequence_++;
  for (int id = 1; id <= kMaxRobots; ++id) {
    const Teammate& m = mates_[static_cast<std::size_t>(id - 1)];
    if (id == node_.robotId() || !m.heard ||
        now - m.last_receive_utime > options_.picture.present_timeout_us) {
      continue;
    }
    p.links.push_back({static_cast<std::uint8_t>(id), m.last_send_utime, m.last_receive_utime});
  }
  if (own_robot_ && now - own_robot_received_ <= options_.fresh_us) p.pose = toPacket(*own_robot_);
  if (own_ball_ && own_ball_->valid && now - own_ball_received_ <= options_.fresh_us) {
    p.ball = toPacket(*own_ball_);
  }
  if (!own_obstacles_.empty() && now - own_obstacles_received_ <= options_.fresh_us) {
    p.obstacles = own_obstacles_;
  }
  // Stamped last, as close to the send as we can.
  p.send_utime = node_.now();
  // Kept ascending (a step back of our own clock starts the list afresh).
  if (!recent_sends_.empty() && recent_sends_.back() > p.send_utime) recent_sends_.clear();
  recent_sends_.push_back(p.send_utime);
  // Echoes come back within a round trip; keep twice the longest one counted (and a bound).
  while (!recent_sends_.empty() &&
         (recent_sends_.size() > 256 ||
          recent_sends_.front() < p.send_utime - 2 * options_.offset.max_round_trip_us)) {
    recent_sends_.pop_front();
  }
  std::vector<std::uint8_t> bytes;
  try {
    bytes = encodePacket(p, options_.key);
  } catch (const std::invalid_argument& e) {
    node_.reportError("encode", e.what());
    return;
  }
  if (link_.send(bytes)) {
    ++counters_.sent;
  } else {
    ++counters_.send_failures;
    node_.reportError("send", "the team packet could not be sent");
  }
}

void TeamcommNode::pollLink() {
  int read = 0;
  link_.poll([this, &read](std::span<const std::uint8_t> bytes, Utime age_us) {
    ++read;
    onDatagram(bytes, age_us);
  });
  if (link_fd_ < 0) return;
  // Teammates' packets wait in the socket until we next send or publish: the kernel stamped their
  // arrival (the link's age), so round trips and the gate see the same times, and the link wakes
  // some 30 times a second instead of for each of its ~120 datagrams (issue 32). A read that
  // finds a flood's worth waits on the socket (as fast as the node can read, so the teammates'
  // packets among the junk are not lost to a full buffer) until the flood has been over a while.
  const Utime steady = node_.clock().monotonicNow();
  if (read >= kFloodDatagramsPerRead) {
    watch_link_until_ = steady + kWatchAfterFlood_us;
    if (!link_watch_) link_watch_ = node_.watchFd(link_fd_, [this] { pollLink(); });
  } else if (link_watch_ && steady >= watch_link_until_) {
    node_.unwatchFd(*link_watch_);
    link_watch_.reset();
  }
}

bool TeamcommNode::waitsOnLink() const {
  return link_watch_.has_value();
}

void TeamcommNode::reject(Reject reason, int claimed_robot, const std::string& detail) {
  ++counters_.rejected[static_cast<std::size_t>(reason)];
  if (claimed_robot >= 1 && claimed_robot <= kMaxRobots && claimed_robot != node_.robotId()) {
    ++mates_[static_cast<std::size_t>(claimed_robot - 1)].rejected;
  }
  node_.reportError("rejected_" + std::string(rejectName(reason)), detail);
}

void TeamcommNode::onDatagram(std::span<const std::uint8_t> bytes, Utime age_us) {
  const Utime received = node_.now() - age_us;
  // The sender byte, unauthenticated: only for attributing a refusal.
  const int claimed = bytes.size() > 6 ? bytes[6] : 0;
  DecodeResult decoded = decodePacket(bytes, options_.key);
  if (!decoded.packet) {
    reject(
        decoded.reason, claimed,
        std::to_string(bytes.size()) + "-byte datagram claiming robot " + std::to_string(claimed));
    return;
  }
  const TeamPacket& p = *decoded.packet;
  if (p.robot_id == node_.robotId()) {
    onOwnPacket(p, received);
    return;
  }
  Teammate& mate = mates_[static_cast<std::size_t>(p.robot_id - 1)];
  mate.last_authenticated = received;
  const std::optional<RoundTrip> trip = echoedRoundTrip(p, received);
  if (const std::optional<Reject> refused = admitTeammatePacket(p, mate, trip, received)) {
    refuseTeammatePacket(p, mate, *refused, received);
    return;
  }
  acceptTeammatePacket(p, mate, trip, received);
  picture_.setReport(p.robot_id, teammateReport(p, mate, received));
}

void TeamcommNode::onOwnPacket(const TeamPacket& p, Utime received) {
  // Our own multicast looped back (within moments, on our own clock) is ignored; one of our
  // packets from longer ago, or one we never sent, is someone replaying it.
  if (!options_.expect_own_echo || p.sequence >= next_sequence_ ||
      next_sequence_ - p.sequence > 64 || received - p.send_utime > kOwnEchoMaxAge_us ||
      received < p.send_utime) {
    reject(Reject::kReplay, 0, "our own packet " + std::to_string(p.sequence) + " replayed");
    return;
  }
  ++counters_.own_echo;
}

std::optional<Reject> TeamcommNode::admitTeammatePacket(const TeamPacket& p, Teammate& mate,
                                                        const std::optional<RoundTrip>& trip,
                                                        Utime received) {
  std::optional<Reject> refused =
      gate_.admit(p, received, offsetAt(mate.offset, received), trip.has_value());
  if (refused == Reject::kStale && trip && learnClockStep(p, mate, *trip)) {
    refused = gate_.admit(p, received, offsetAt(mate.offset, received), true);
  }
  if (refused == Reject::kStale && forgetStaleOffset(p, mate, received)) {
    refused = gate_.admit(p, received, std::nullopt, false);
  }
  return refused;
}

bool TeamcommNode::learnClockStep(const TeamPacket& p, Teammate& mate, const RoundTrip& trip) {
  // Stale by its stamps, yet made after our recent packet: the sender's clock has stepped (or
  // ours). Its round trips say by how much; once a few agree, the offset restarts from them.
  if (mate.offset.add(trip) != RoundTripUse::kStep) return false;
  ++counters_.clock_steps;
  const ClockStep step = *mate.offset.lastStep();
  node_.reportError("clock_step", fmt::format("robot {}'s clock stepped by {:+.3f} s (round "
                                              "trips); its offset restarts from them",
                                              p.robot_id, step.size_us / 1e6));
  return true;
}

bool TeamcommNode::forgetStaleOffset(const TeamPacket& p, Teammate& mate, Utime received) {
  if (mate.stale_since < 0 || received - mate.stale_since < options_.offset_reset_after_stale_us ||
      !mate.offset.estimate(received)) {
    return false;
  }
  // No round trip has told a step from a replay (none echoed us, or none was plausible): its
  // packets are judged as before the first round trip (the sequence check still refuses replays)
  // until round trips re-seed the offset.
  ++counters_.offset_resets;
  mate.offset.reset();
  node_.reportError(
      "offset_reset",
      fmt::format("robot {}: every packet refused as stale for {:.1f} s; its "
                  "clock offset is forgotten and re-learnt",
                  p.robot_id, static_cast<double>(received - mate.stale_since) / 1e6));
  return true;
}

void TeamcommNode::refuseTeammatePacket(const TeamPacket& p, Teammate& mate, Reject reason,
                                        Utime received) {
  std::string detail =
      "robot " + std::to_string(p.robot_id) + " sequence " + std::to_string(p.sequence);
  if (reason == Reject::kStale) {
    // By how much its send time misses ours (positive: sent in our future).
    const auto offset = offsetAt(mate.offset, received);
    mate.stale_by_us = static_cast<double>(p.send_utime - received) - offset.value_or(0.0);
    if (mate.stale_since < 0) mate.stale_since = received;
    // Echoed all the same when it is new (not a replay): its step shows in the round trips our
    // packets then make with it, on both sides (a teammate that refuses ours as stale echoes
    // them for us). An echo naming none of its recent packets is refused over there.
    if (gate_.newer(p.robot_id, p.sequence)) {
      mate.heard = true;
      mate.last_send_utime = p.send_utime;
      mate.last_receive_utime = received;
    }
    detail = fmt::format(
        "robot {}'s packet sent {:.3f} s {} it arrived {}", p.robot_id,
        std::abs(mate.stale_by_us) / 1e6, mate.stale_by_us > 0 ? "after" : "before",
        offset ? "by its clock offset estimate (a clock step?)" : "(no clock offset known yet)");
  }
  reject(reason, p.robot_id, detail);
}

void TeamcommNode::acceptTeammatePacket(const TeamPacket& p, Teammate& mate,
                                        const std::optional<RoundTrip>& trip, Utime received) {
  if (gate_.restarts(p.robot_id) != mate.sequence_restarts) {
    counters_.sequence_restarts += gate_.restarts(p.robot_id) - mate.sequence_restarts;
    mate.sequence_restarts = gate_.restarts(p.robot_id);
    node_.reportError("sequence_restart",
                      fmt::format("robot {} restarted with a lower sequence number (a clock set "
                                  "back): followed from {}",
                                  p.robot_id, p.sequence));
  }
  mate.stale_since = -1;
  ++counters_.accepted;
  ++mate.received;
  // The round trip: our packet (t1, our clock) reached the teammate at t2 (its clock); it sent
  // this one at t3 (its clock) and we received it at t4.
  if (trip) mate.offset.add(*trip);
  mate.heard = true;
  mate.last_send_utime = p.send_utime;
  mate.last_receive_utime = received;
}

Report TeamcommNode::teammateReport(const TeamPacket& p, const Teammate& mate,
                                    Utime received) const {
  Report report;
  report.received_utime = received;
  if (p.pose) {
    const PacketPose& q = *p.pose;
    perception::RobotEstimate& r = report.robot;
    r.utime = toOurClock(mate, q.utime, p.send_utime, received);
    r.pose = {q.x, q.y, q.phi};
    r.vx = q.vx;
    r.vy = q.vy;
    r.omega = q.omega;
    const auto& c = q.covariance;
    r.covariance << c[0], c[1], c[2], c[1], c[3], c[4], c[2], c[4], c[5];
    r.status = static_cast<perception::LocalizationStatus>(q.status);
    r.twin_ambiguous = q.twin_ambiguous;
    r.since_vision_us = q.since_vision_us;
  } else if (const Report* previous = picture_.report(p.robot_id)) {
    // Heard, but its estimate is not fresh: the last pose it sent, ageing.
    report.robot = previous->robot;
  } else {
    // Heard, never with a pose: present with an unknown, very uncertain one.
    report.robot.utime = received;
    report.robot.covariance = Eigen::Matrix3d::Identity() * kMaxVariance;
  }
  if (p.ball) {
    const PacketBall& b = *p.ball;
    perception::BallEstimate& e = report.ball;
    e.valid = true;
    e.utime = toOurClock(mate, b.utime, p.send_utime, received);
    e.last_seen_utime = toOurClock(mate, b.last_seen_utime, p.send_utime, received);
    e.x = b.x;
    e.y = b.y;
    e.vx = b.vx;
    e.vy = b.vy;
    e.covariance << b.covariance[0], b.covariance[1], b.covariance[1], b.covariance[2];
  }
  return report;
}

std::optional<RoundTrip> TeamcommNode::echoedRoundTrip(const TeamPacket& p, Utime received) const {
  for (const LinkEcho& echo : p.links) {
    if (echo.robot_id != node_.robotId()) continue;
    if (!std::binary_search(recent_sends_.begin(), recent_sends_.end(), echo.their_send_utime)) {
      return std::nullopt;
    }
    return RoundTrip{echo.their_send_utime, echo.our_receive_utime, p.send_utime, received};
  }
  return std::nullopt;
}

Utime TeamcommNode::toOurClock(const Teammate& mate, Utime their_utime, Utime their_send_utime,
                               Utime our_receive_utime) const {
  if (auto ours = mate.offset.toOurs(their_utime)) return *ours;
  return our_receive_utime - (their_send_utime - their_utime);
}

void TeamcommNode::publishTeamState() {
  if (link_fd_ >= 0) pollLink();
  const Utime now = node_.now();
  if (own_robot_ && now - own_robot_received_ <= options_.picture.present_timeout_us) {
    Report own;
    own.robot = *own_robot_;
    if (own_ball_) own.ball = *own_ball_;
    own.received_utime = own_robot_received_;
    picture_.setReport(node_.robotId(), own);
  }
  TeamBallResult ball;
  perception::TeamState state = picture_.picture(now, &ball);
  int present = 0;
  double worst_uncertainty_ms = 0.0;
  for (int id = 1; id <= kMaxRobots; ++id) {
    perception::TeammateState& out = state.robots[static_cast<std::size_t>(id - 1)];
    if (id == node_.robotId()) continue;
    const Teammate& m = mates_[static_cast<std::size_t>(id - 1)];
    out.packets_received = m.received;
    out.packets_rejected = m.rejected;
    if (const auto e = m.offset.estimate(now)) {
      out.clock_offset_us = static_cast<std::int64_t>(std::llround(e->offset_us));
      out.round_trip_us = e->min_round_trip_us;
      if (out.present)
        worst_uncertainty_ms = std::max(worst_uncertainty_ms, e->uncertainty_us / 1e3);
    }
    if (out.present) ++present;
  }
  updateClockWarnings(now);
  updateKernelDrops(now);
  msg::toMessage(state, team_state_msg_);
  node_.publish(bus::channels::kTeamState, team_state_msg_);
  node_.setMetric("teammates_present", present);
  node_.setMetric("offset_uncertainty_ms", worst_uncertainty_ms);
  node_.setMetric("packets_rejected", static_cast<double>(counters_.rejectedTotal()));
  node_.setMetric("team_ball_rejected", static_cast<double>(ball.rejected.size()));
  node_.setMetric("team_ball_mirrored", static_cast<double>(ball.mirrored.size()));
  node_.setMetric("team_ball_superseded", static_cast<double>(ball.superseded.size()));
  node_.setMetric("clock_steps", static_cast<double>(counters_.clock_steps));
  node_.setMetric("offset_resets", static_cast<double>(counters_.offset_resets));
}

void TeamcommNode::updateKernelDrops(Utime now) {
  const std::int64_t total = link_.kernelDrops();
  if (total < 0) return;
  node_.setMetric("kernel_drops", static_cast<double>(total));
  constexpr Utime kWindow_us = 2'000'000;
  kernel_drops_.emplace_back(now, total);
  while (kernel_drops_.size() > 1 &&
         (kernel_drops_.front().first < now - kWindow_us || kernel_drops_.front().first > now)) {
    kernel_drops_.pop_front();
  }
  const std::int64_t recent = total - kernel_drops_.front().second;
  std::string reason;
  if (recent > 0) {
    reason = fmt::format(
        "team socket: the kernel dropped {} datagrams in {:.1f} s ({} since start; receive "
        "buffer full: a flood, or this node too slow)",
        recent, static_cast<double>(now - kernel_drops_.front().first) / 1e6, total);
  }
  node_.status().setWarning("kernel_drops", reason);
}

void TeamcommNode::updateClockWarnings(Utime now) {
  for (int id = 1; id <= kMaxRobots; ++id) {
    if (id == node_.robotId()) continue;
    const Teammate& m = mates_[static_cast<std::size_t>(id - 1)];
    std::string reason;
    // Only while it is still sending: a teammate that went away is the picture's to report.
    const bool sending = m.last_authenticated >= 0 &&
                         now - m.last_authenticated <= options_.picture.present_timeout_us;
    if (!sending) {
      // nothing
    } else if (m.stale_since >= 0) {
      reason = fmt::format(
          "robot {}: every packet refused as stale for {:.1f} s (sent {:.3f} s {} it arrived by "
          "its clock offset: a clock step?)",
          id, static_cast<double>(now - m.stale_since) / 1e6, std::abs(m.stale_by_us) / 1e6,
          m.stale_by_us > 0 ? "after" : "before");
    } else if (m.offset.converging()) {
      if (const auto step = m.offset.lastStep()) {
        reason = fmt::format(
            "robot {}'s clock stepped by {:+.3f} s {:.1f} s ago; its offset is "
            "re-converging",
            id, step->size_us / 1e6, static_cast<double>(now - step->confirmed_utime) / 1e6);
      } else {
        reason = fmt::format(
            "robot {}'s clock offset is re-learnt after its packets were refused "
            "as stale",
            id);
      }
    }
    node_.status().setWarning("clock_robot" + std::to_string(id), reason);
  }
}

}  // namespace fieldline::teamcomm
