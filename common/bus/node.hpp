// The node base: the only code in the project that talks to LCM.
//
//   SystemClock clock;
//   bus::Node node({.process = "fusion", .robot_id = 3, .url = bus::robotBusUrl(3)}, clock);
//   node.subscribe(bus::channels::kOdometry, [&](const odometry_t& m) { ... });
//   node.every(20 * kMicrosPerMilli, [&] { node.publish(bus::channels::kRobotState, state); });
//   node.run();  // until SIGINT/SIGTERM or requestStop()
//
// Every received message is decoded, validated (bus/validate.hpp), checked against the clock
// (no utime from the future) and counted before the handler sees it; a bad one is counted with
// its reason and dropped. publish() fills header.utime_published, seq and robot_id; the caller
// sets header.utime, the physical time of what the message describes. publish() also sets
// header.publisher_id, a random id of this node, so receivers track seq per publisher.
// SERVICE_STATUS goes out once per second on the primary bus.
//
// The event loop waits in one poll() on every bus's LCM socket and on the file descriptors
// given to watchFd() (a serial line, a UDP socket), with the timeout to the next timer, so a
// node that has nothing to do sleeps. Nothing polls.
//
// Time: Clock::now() only stamps (headers, "from the future" checks, status). Timers (every(),
// at(), after(), the status period) run on Clock::monotonicNow(), which never steps: a step of the
// system clock (time sync on a robot) neither stalls nor bursts them. A SimulatedClock drives
// both readings (advance() elapses time, step() moves the wall time alone), so memq:// tests
// fire timers by advancing the clock.
#pragma once

#include <poll.h>
#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "common/bus/channels.hpp"
#include "common/bus/checked_decode.hpp"
#include "common/bus/io.hpp"
#include "common/bus/status.hpp"
#include "common/bus/urls.hpp"
#include "common/bus/validate.hpp"
#include "common/time/clock.hpp"

namespace fieldline::bus {

// The bus could not be opened (e.g. no multicast route). what() says what to run.
class BusError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One LCM connection; several nodes in one process may share it (memq:// tests).
class Connection {
 public:
  // Opens `url` and checks it works; throws BusError with a remedy otherwise.
  static std::shared_ptr<Connection> open(const std::string& url);
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;
  const std::string& url() const { return url_; }
  // Datagrams this process's own receive socket of a udpm bus has read (what it woke for); -1 for
  // other providers, 0 before the first subscription.
  std::int64_t datagramsReceived() const;

 private:
  friend class Node;
  struct Impl;
  explicit Connection(std::string url);
  std::string url_;
  std::unique_ptr<Impl> impl_;
};

struct NodeOptions {
  // Process name shown in SERVICE_STATUS and logs, e.g. "camera".
  std::string process;
  // 1..6 on a robot, 0 for the simulator and tools.
  int robot_id = 0;
  // Primary bus; empty means robotBusUrl(robot_id) (simBusUrl() for robot 0).
  std::string url;
  // Received messages with utime or utime_published beyond now + this are rejected as from the
  // future.
  Utime future_tolerance_us = 500'000;
  // Received messages published longer ago than this (receiver's clock) are rejected as stale:
  // a log played onto a live bus, a stopped sender's backlog.
  Utime max_age_us = 10 * kMicrosPerSecond;
  // Received messages whose utime_published - utime exceeds this are rejected (absurd latency).
  Utime max_latency_us = 10 * kMicrosPerSecond;
  // A required input (requireInput) below its rate for longer than this makes the state WARN.
  Utime input_grace_us = 2 * kMicrosPerSecond;
  // Period of SERVICE_STATUS; 0 disables it.
  Utime status_period_us = kMicrosPerSecond;
  // header.publisher_id of everything this node sends; 0 draws a random one. Replays set a fixed
  // id so that two runs give byte-identical output.
  std::int64_t publisher_id = 0;
};

using BusId = int;
inline constexpr BusId kPrimaryBus = 0;

class Node {
 public:
  Node(NodeOptions options, const Clock& clock);
  // Uses an existing connection as the primary bus (in-process tests over memq://).
  Node(NodeOptions options, const Clock& clock, std::shared_ptr<Connection> primary);
  // The node keeps a reference to its clock: a temporary would dangle (it once crashed every
  // fusion process), so the compiler refuses one.
  Node(NodeOptions options, const Clock&& clock) = delete;
  Node(NodeOptions options, const Clock&& clock, std::shared_ptr<Connection> primary) = delete;
  ~Node();
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  // Opens a further bus (e.g. the simulator's) and returns its id for subscribe/publish.
  BusId addBus(const std::string& url);
  BusId addBus(std::shared_ptr<Connection> connection);

  template <typename Msg>
  void subscribe(Channel<Msg> channel,
                 std::type_identity_t<std::function<void(const Msg&)>> handler,
                 BusId bus = kPrimaryBus) {
    const std::string name(channel.name);
    checkDeclaredInput(name);
    // The message object is reused, so big messages (images) decode without allocating; the
    // generated decoders are hardened to resize every array (cmake/harden_lcm_decode.py). The
    // channel's statistics are found once (`slot`), not by name per message.
    subscribeRaw(name, bus,
                 [this, name, handler = std::move(handler), msg = Msg{}, slot = -1](
                     const void* data, int size) mutable {
                   // The same checks as a log's events get (checked_decode.hpp).
                   if (auto rejection = decodeChecked(msg, data, size)) {
                     reject(name, rejection->kind, rejection->text);
                     return;
                   }
                   if (!acceptHeader(name, slot, msg.header)) return;
                   timed([&] { handler(msg); });
                 });
  }

  // As subscribe(), for images whose pixels the handler reads only while it runs: the same checks,
  // statuses and rejections, but the pixels are not copied out of the receive buffer (ImageView,
  // checked_decode.hpp). Region tracking's CAMERA_IMAGE: a copy of 150 KB a frame less (issue 32).
  void subscribeImage(Channel<image_t> channel, std::function<void(const ImageView&)> handler,
                      BusId bus = kPrimaryBus);

  // As subscribe(), but the node does not wake for the channel: on a udpm bus its messages wait
  // in a socket of their own and are handled, in their order, before the node's next timer or
  // status and before every message of another channel on that bus that arrived after them (the
  // deferred socket is read after each batch of the bus's datagrams, before the batch is
  // handled; other buses' messages and watched fds do not wait for them). For an input only the
  // newest of which matters when the node next acts (the pilot's pose at its next command): a
  // wake-up less per message (issue 32). Its header checks and status stamps use the time it is
  // handled. Other providers (memq://): the same as subscribe().
  template <typename Msg>
  void subscribeDeferred(Channel<Msg> channel,
                         std::type_identity_t<std::function<void(const Msg&)>> handler,
                         BusId bus = kPrimaryBus) {
    subscribe(channel, std::move(handler), bus);
    deferLastSubscription();
  }

  // Every message on a bus, undecoded, with its channel name (tools that watch any traffic).
  // Nothing is validated or counted here.
  void subscribeAllRaw(
      std::function<void(const std::string& channel, const void* data, int size)> handler,
      BusId bus = kPrimaryBus);

  // Publishes `msg` (its header.utime set by the caller) after filling the rest of the header.
  // An invalid message (NaN, bad sizes) is counted as an error and not sent; returns false then.
  template <typename Msg>
  bool publish(Channel<Msg> channel, Msg& msg, BusId bus = kPrimaryBus) {
    // Found by the channel's index (or, for a name outside the table, by name): no string is
    // made or compared per message (issue 32).
    Outlet& out = outlet(channel.name, channel.index);
    if (!declaredOutput(out)) return false;
    stampHeader(out, msg.header);
    if (auto problem = validate(msg)) {
      reportError("invalid_output", out.name + ": " + *problem);
      return false;
    }
    // Only a message that goes out uses up its seq number: receivers count gaps as losses.
    ++out.next_seq;
    const int size = msg.getEncodedSize();
    encode_buffer_.resize(static_cast<std::size_t>(size));
    if (msg.encode(encode_buffer_.data(), 0, size) != size) {
      reportError("encode", out.name + ": encoding failed");
      return false;
    }
    return publishRaw(out, msg.header, bus);
  }

  // Publishes already-encoded bytes unchanged (log replay, forwarding, tests of bad input).
  bool publishEncoded(std::string_view channel, const void* data, int size,
                      BusId bus = kPrimaryBus);

  using TimerId = std::int64_t;
  // Calls `fn` every `period_us` of elapsed (monotonic) time, first one period from now.
  TimerId every(Utime period_us, std::function<void()> fn);
  // Calls `fn` once, when clock time `when` is reached; the delay is taken when the timer is
  // set, so a later step of the clock does not move it.
  TimerId at(Utime when, std::function<void()> fn);
  // Calls `fn` once, `delay_us` of elapsed (monotonic) time from now: a deadline a node sets
  // again as it goes (the next packet due) instead of polling for it with every().
  TimerId after(Utime delay_us, std::function<void()> fn);
  // Moves a timer's next call to `delay_us` of elapsed time from now; a periodic one goes on
  // every period from there (a tick moved to an event that does the tick's work, so the two
  // share a wake-up: the motor bridge's command tick at the controller's sample, issue 32).
  // Safe from inside any callback, the timer's own included; false for an id that is no longer
  // set (a one-shot that fired, a cancelled timer).
  bool moveTimer(TimerId id, Utime delay_us);
  // Removes a timer: it does not fire again, not even later in the current round of due timers.
  // Safe from inside any callback; false for an id that is no longer set.
  bool cancelTimer(TimerId id);
  // Handles now what waits for the deferred subscriptions (subscribeDeferred), as the loop does
  // before a timer: for a watched fd's callback that acts on their newest messages. What it
  // handles arrived after every message the node has handled on that bus. From inside this
  // node's deferred handlers it reads nothing, of any bus (no handler of another bus runs inside
  // one); from inside a deferred handler of another node on the same connection it reads nothing
  // more of that connection's deferred socket (the batch being handled comes first; that guard
  // is the socket's, UdpmReceiver::receive).
  void handleDeferred() { drainDeferred(); }

  using WatchId = int;
  // Calls `on_ready` whenever `fd` is readable (or reports hang-up or an error: the callback
  // finds out by reading). The node does not own `fd`; unwatch it before closing it. A watch
  // whose fd turns out invalid is removed and counted as a "watch_fd" error.
  WatchId watchFd(int fd, std::function<void()> on_ready);
  // Stops watching; safe from inside any callback, and for ids already removed.
  void unwatchFd(WatchId id);
  std::size_t watchedFdCount() const { return watches_.size(); }

  // Waits up to timeout_ms for traffic on the buses and the watched fds, handles what arrived,
  // fires due timers and status. Returns the number of messages handled.
  int spinOnce(int timeout_ms);
  // Milliseconds until the next timer or status is due (0 if one is due now), at most max_ms.
  int msUntilNextTimer(int max_ms) const;
  // Spins until requestStop() or SIGINT/SIGTERM. Returns 0.
  int run();
  void requestStop() { stop_requested_ = true; }
  bool stopRequested() const;

  // Declares an input this process needs at `min_rate_hz` or more (e.g. CAMERA_IMAGE at 20 Hz):
  // below it for longer than options().input_grace_us, SERVICE_STATUS says WARN with the reason
  // ("CAMERA_IMAGE silent 2.1 s"), and ok again once it recovers.
  template <typename Msg>
  void requireInput(Channel<Msg> channel, double min_rate_hz) {
    status_.requireRate(std::string(channel.name), Direction::kIn, min_rate_hz);
  }
  // The same for a channel this process publishes from a device's data flow (ODOMETRY from the
  // motor controller's samples): its state follows the flow, not only the open device.
  template <typename Msg>
  void requireOutput(Channel<Msg> channel, double min_rate_hz) {
    status_.requireRate(std::string(channel.name), Direction::kOut, min_rate_hz);
  }
  // What this process reads and writes (common/bus/io.hpp), declared after its subscriptions:
  // throws std::logic_error when a subscription is not declared or a required input has none.
  // From then on a subscription to an undeclared channel throws too, and a publication of an
  // undeclared channel is counted as an "undeclared_output" error and not sent.
  void declareIo(ProcessIo io);
  const std::optional<ProcessIo>& io() const { return io_; }

  // The random id this node puts into header.publisher_id (drawn at construction).
  std::int64_t publisherId() const { return publisher_id_; }

  // Counts an error of `kind` (e.g. "serial_crc") with a message; logs it (rate-limited).
  void reportError(const std::string& kind, const std::string& text);
  // A process-specific number for SERVICE_STATUS, its unit in its name ("render_ms").
  void setMetric(const std::string& name, double value);

  const Clock& clock() const { return clock_; }
  Utime now() const { return clock_.now(); }
  int robotId() const { return options_.robot_id; }
  const NodeOptions& options() const { return options_; }
  const std::string& url(BusId bus = kPrimaryBus) const;
  // Datagrams this process's receive socket of a udpm bus has read, what it woke for
  // (Connection::datagramsReceived).
  std::int64_t busDatagrams(BusId bus = kPrimaryBus) const {
    return buses_.at(static_cast<std::size_t>(bus))->datagramsReceived();
  }
  StatusCollector& status() { return status_; }
  // Publishes SERVICE_STATUS now (also done automatically every status period).
  void publishStatus();
  // Calls `fn` right before each SERVICE_STATUS is taken: metrics computed once per status, not
  // per message.
  void beforeStatus(std::function<void()> fn) { before_status_.push_back(std::move(fn)); }

  // Implementation detail, public only for the LCM callback trampoline.
  struct Subscription;
  using RawHandler = std::function<void(const void* data, int size)>;
  using AllHandler = std::function<void(const std::string& channel, const void* data, int size)>;

 private:
  struct Timer {
    // Monotonic time of the next call.
    Utime next;
    Utime period;  // 0: one-shot; -1: fired or cancelled, removed at the end of fireTimers()
    std::function<void()> fn;
    TimerId id;
  };
  struct Watch {
    WatchId id;
    int fd;
    std::function<void()> on_ready;
  };

  void subscribeRaw(const std::string& channel, BusId bus, RawHandler handler, AllHandler all = {});
  // Makes the newest subscription a deferred one (subscribeDeferred).
  void deferLastSubscription();
  // Handles what waits in the buses' deferred sockets.
  void drainDeferred();
  // A channel this node publishes: its name (made once), next seq, statistics' slot and whether
  // the declaration lists it.
  struct Outlet {
    std::string name;
    std::int64_t next_seq = 0;
    // StatusCollector::slot, made at the first message that goes out (-1 before).
    int status_slot = -1;
    // declareIo's count when `declared` was found (-1: never).
    int declared_for = -1;
    bool declared = true;
  };
  Outlet& outlet(std::string_view channel, int index);
  void checkDeclaredInput(const std::string& channel) const;
  bool declaredOutput(Outlet& out);
  bool publishRaw(Outlet& out, const header_t& header, BusId bus);
  // Fills seq (without using it up), robot_id and utime_published.
  void stampHeader(const Outlet& out, header_t& header);
  // `slot`: the channel's StatusCollector::slot, found at its first accepted message (-1 before).
  bool acceptHeader(const std::string& channel, int& slot, const header_t& header);
  void reject(const std::string& channel, const std::string& kind, const std::string& text);
  void timed(const std::function<void()>& fn);
  void fireTimers();
  TimerId addTimer(Utime next, Utime period, std::function<void()> fn);
  Timer* findTimer(TimerId id);
  Connection& connection(BusId bus);
  // A bad datagram or a message that lost fragments (udpm buses).
  void onBusProblem(BusId bus, const char* kind, const std::string& text);

  NodeOptions options_;
  const Clock& clock_;
  std::int64_t publisher_id_ = 0;
  std::vector<std::shared_ptr<Connection>> buses_;
  std::vector<std::unique_ptr<Subscription>> subscriptions_;
  std::vector<Timer> timers_;
  TimerId next_timer_id_ = 1;
  std::vector<Watch> watches_;
  WatchId next_watch_id_ = 1;
  std::vector<pollfd> poll_fds_;
  std::vector<WatchId> poll_watch_ids_;
  // In the order first published; by a channel's index in kAllChannelNames (-1: none yet).
  std::vector<Outlet> outlets_;
  std::array<int, kAllChannelNames.size()> outlet_by_index_;
  // Declarations made (declareIo).
  int io_count_ = 0;
  // Datagrams the deferred sockets may still be read for in this spin: one budget a spin, as
  // each bus has, so a flood on a deferred channel cannot hold the timers and the status up.
  int deferred_budget_ = 0;
  // spinOnce() is running.
  bool spinning_ = false;
  // drainDeferred() is running (the guard against a nested handleDeferred()).
  bool draining_ = false;
  std::vector<std::uint8_t> encode_buffer_;
  StatusCollector status_;
  // Monotonic time of the next SERVICE_STATUS.
  Utime next_status_;
  std::atomic<bool> stop_requested_{false};
  std::vector<std::pair<std::string, std::int64_t>> logged_errors_;
  std::optional<ProcessIo> io_;
  std::vector<std::function<void()>> before_status_;
};

// Reads the header_t every fieldline message starts with, from encoded bytes of any type.
std::optional<header_t> peekHeader(const void* data, int size);

// Installs SIGINT/SIGTERM handlers that make every Node::run() return (idempotent).
void installStopSignals();
// True once SIGINT or SIGTERM arrived.
bool stopSignalReceived();

}  // namespace fieldline::bus
