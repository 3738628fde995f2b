#include "common/bus/node.hpp"

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <limits>
#include <random>
#include <system_error>

#include <fmt/format.h>
#include <poll.h>
#include <spdlog/spdlog.h>
#include <lcm/lcm-cpp.hpp>

#include "common/bus/systemd_notify.hpp"
#include "common/bus/udpm_receiver.hpp"
#include "common/time/offset_clock.hpp"

namespace fieldline::bus {
namespace {

// Messages stamped by another robot (header.robot_id neither 0 nor ours) are on that robot's
// clock, which may be off ours by up to about a second (the simulated team's robot clocks, a robot
// without time sync): the future and stale windows widen by this for them. Messages of robot 0
// (the simulator, tools) are on the true time and are checked against toTruth(clock, now).
constexpr Utime kOtherClockTolerance_us = 1'500'000;

std::atomic<bool> g_stop_signal{false};
constexpr int kMaxMessagesPerSpin = 200;

// Sets a flag back to false when the scope ends, however it ends.
struct ClearOnExit {
  bool& flag;
  ~ClearOnExit() { flag = false; }
};

extern "C" void onStopSignal(int) {
  g_stop_signal = true;
}

std::string remedyFor(const std::string& url) {
  if (url.rfind("udpm://", 0) == 0 || url.empty()) {
    return "LCM bus '" + url +
           "' is not usable: LCM needs a multicast route covering 224.0.0.0/4. Run scripts/setup, "
           "or as root: ip link set lo multicast on; ip route replace 224.0.0.0/4 dev lo "
           "(without root: unshare -rn and the same commands inside the namespace).";
  }
  return "LCM bus '" + url + "' could not be opened (check the URL's provider and options).";
}

}  // namespace

void installStopSignals() {
  struct sigaction sa {};
  sa.sa_handler = onStopSignal;
  // A second Ctrl-C during a hung shutdown gets the default action.
  sa.sa_flags = SA_RESETHAND;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

bool stopSignalReceived() {
  return g_stop_signal.load();
}

std::optional<header_t> peekHeader(const void* data, int size) {
  // Encoded LCM: the outer type's 8-byte fingerprint, then the fields; a nested struct carries no
  // fingerprint of its own, so the header follows directly.
  constexpr int kFingerprintBytes = 8;
  header_t h{};
  if (size < kFingerprintBytes ||
      h._decodeNoHash(data, kFingerprintBytes, size - kFingerprintBytes) < 0) {
    return std::nullopt;
  }
  return h;
}

// ---------------------------------------------------------------------------------------------
struct Node::Subscription {
  Node* node;
  std::string channel;
  RawHandler handler;
  // Set instead of handler for subscribeAllRaw: also gets the channel name.
  AllHandler all;
  Connection* connection = nullptr;
  lcm::Subscription* lcm_subscription = nullptr;
  // Received by the connection's deferred socket (Node::subscribeDeferred).
  bool deferred = false;
};

// A udpm bus is received by a socket of the node's own (udpm_receiver.hpp) and published through
// LCM; other providers (memq://, file://) go through LCM both ways.
struct Connection::Impl {
  lcm::LCM lcm;
  std::optional<UdpmReceiver> receiver;
  // The deferred subscriptions' socket: not waited on, read by Node::drainDeferred.
  std::optional<UdpmReceiver> deferred_receiver;
  std::optional<UdpmAddress> address;
  // Every node's subscriptions on a udpm bus (several nodes may share a connection).
  std::vector<Node::Subscription*> subscriptions;
  // Reused for subscribeAllRaw handlers, which take a std::string.
  std::string channel_name;

  explicit Impl(const std::string& url) : lcm(url) {
    const char* fallback = std::getenv("LCM_DEFAULT_URL");
    const std::string effective =
        !url.empty() ? url : (fallback && *fallback ? fallback : "udpm://239.255.76.67:7667");
    address = parseUdpmUrl(effective);
    if (address) receiver.emplace(*address);
  }

  // The filter follows the subscriptions: the kernel passes only what some node here reads.
  void updateFilter() {
    std::vector<std::string> channels, deferred_channels;
    bool everything = false;
    for (const Node::Subscription* sub : subscriptions) {
      everything = everything || static_cast<bool>(sub->all);
      auto& list = sub->deferred ? deferred_channels : channels;
      if (!sub->all && std::find(list.begin(), list.end(), sub->channel) == list.end())
        list.push_back(sub->channel);
    }
    // A socket opens with its first channel (one only deferred channels use has none).
    if (receiver->fd() >= 0 || everything || !channels.empty())
      receiver->setChannels(channels, everything);
    if (!deferred_channels.empty() && !deferred_receiver) deferred_receiver.emplace(*address);
    if (deferred_receiver && (deferred_receiver->fd() >= 0 || !deferred_channels.empty()))
      deferred_receiver->setChannels(deferred_channels, false);
  }

  // To the subscriptions of the socket it came from (`deferred`: the deferred one).
  void dispatch(std::string_view channel, const void* data, int size, bool deferred = false) {
    // Index loop: a handler may subscribe.
    for (std::size_t i = 0; i < subscriptions.size(); ++i) {
      Node::Subscription* sub = subscriptions[i];
      if (sub->deferred != deferred) continue;
      if (sub->all) {
        channel_name.assign(channel);
        sub->all(channel_name, data, size);
      } else if (sub->channel == channel) {
        sub->handler(data, size);
      }
    }
  }

  int waitFd() { return receiver ? receiver->fd() : lcm.getFileno(); }
};

Connection::Connection(std::string url)
    : url_(std::move(url)), impl_(std::make_unique<Impl>(url_)) {}
Connection::~Connection() = default;

std::shared_ptr<Connection> Connection::open(const std::string& url) {
  std::shared_ptr<Connection> c;
  try {
    c.reset(new Connection(url));
  } catch (const std::invalid_argument& e) {
    throw BusError(e.what());
  }
  if (!c->impl_->lcm.good()) throw BusError(remedyFor(url));
  return c;
}

std::int64_t Connection::datagramsReceived() const {
  return impl_->receiver ? impl_->receiver->datagrams() : -1;
}

// ---------------------------------------------------------------------------------------------
namespace {
void dispatchRaw(const lcm::ReceiveBuffer* rbuf, const std::string& channel, void* context) {
  auto* sub = static_cast<Node::Subscription*>(context);
  if (sub->all) {
    sub->all(channel, rbuf->data, static_cast<int>(rbuf->data_size));
  } else {
    sub->handler(rbuf->data, static_cast<int>(rbuf->data_size));
  }
}
}  // namespace

Node::Node(NodeOptions options, const Clock& clock)
    : Node(options, clock,
           Connection::open(!options.url.empty()   ? options.url
                            : options.robot_id > 0 ? robotBusUrl(options.robot_id)
                                                   : simBusUrl())) {}

Node::Node(NodeOptions options, const Clock& clock, std::shared_ptr<Connection> primary)
    : options_(std::move(options)),
      clock_(clock),
      status_(options_.process, options_.robot_id, clock.now()),
      next_status_(clock.monotonicNow() + options_.status_period_us) {
  outlet_by_index_.fill(-1);
  if (options_.url.empty()) options_.url = primary->url();
  buses_.push_back(std::move(primary));
  status_.setRateGrace(options_.input_grace_us);
  // Random, not the pid: pids repeat across robots and containers. Non-zero, so 0 means "unset".
  publisher_id_ = options_.publisher_id;
  std::random_device entropy;
  while (publisher_id_ == 0) {
    publisher_id_ = static_cast<std::int64_t>((static_cast<std::uint64_t>(entropy()) << 32) ^
                                              static_cast<std::uint64_t>(entropy()));
  }
}

Node::~Node() {
  // Nodes may share a connection that outlives them: stop its callbacks into this node.
  for (auto& sub : subscriptions_) {
    if (sub->lcm_subscription) sub->connection->impl_->lcm.unsubscribe(sub->lcm_subscription);
    auto& impl = *sub->connection->impl_;
    if (impl.receiver) std::erase(impl.subscriptions, sub.get());
  }
  for (auto& bus : buses_) {
    if (bus->impl_->receiver && bus->impl_->receiver->fd() >= 0) {
      try {
        bus->impl_->updateFilter();
      } catch (const std::exception& e) {
        spdlog::warn("[{}] {}", options_.process, e.what());
      }
    }
  }
}

BusId Node::addBus(const std::string& url) {
  return addBus(Connection::open(url));
}

BusId Node::addBus(std::shared_ptr<Connection> connection) {
  buses_.push_back(std::move(connection));
  return static_cast<BusId>(buses_.size() - 1);
}

const std::string& Node::url(BusId bus) const {
  return buses_.at(static_cast<std::size_t>(bus))->url();
}

Connection& Node::connection(BusId bus) {
  if (bus < 0 || static_cast<std::size_t>(bus) >= buses_.size()) {
    throw std::out_of_range("no bus with id " + std::to_string(bus));
  }
  return *buses_[static_cast<std::size_t>(bus)];
}

void Node::subscribeRaw(const std::string& channel, BusId bus, RawHandler handler, AllHandler all) {
  auto sub = std::make_unique<Subscription>();
  sub->node = this;
  sub->channel = channel;
  sub->handler = std::move(handler);
  sub->all = std::move(all);
  sub->connection = &connection(bus);
  auto& impl = *sub->connection->impl_;
  if (impl.receiver) {
    impl.subscriptions.push_back(sub.get());
    subscriptions_.push_back(std::move(sub));
    try {
      impl.updateFilter();
    } catch (const std::system_error& e) {
      throw BusError("LCM bus '" + connection(bus).url() + "': cannot receive: " + e.what());
    }
    return;
  }
  sub->lcm_subscription =
      impl.lcm.subscribeFunction(channel, &dispatchRaw, static_cast<void*>(sub.get()));
  // Big messages (images) come in bursts; let a slow handler fall behind a little, not forever.
  if (sub->lcm_subscription) sub->lcm_subscription->setQueueCapacity(60);
  subscriptions_.push_back(std::move(sub));
}

void Node::subscribeImage(Channel<image_t> channel, std::function<void(const ImageView&)> handler,
                          BusId bus) {
  const std::string name(channel.name);
  checkDeclaredInput(name);
  subscribeRaw(name, bus,
               [this, name, handler = std::move(handler), view = ImageView{}, slot = -1](
                   const void* data, int size) mutable {
                 if (auto rejection = decodeCheckedView(view, data, size)) {
                   reject(name, rejection->kind, rejection->text);
                   return;
                 }
                 if (!acceptHeader(name, slot, view.fields.header)) return;
                 timed([&] { handler(view); });
               });
}

void Node::deferLastSubscription() {
  Subscription& sub = *subscriptions_.back();
  auto& impl = *sub.connection->impl_;
  // Other providers deliver it as any subscription.
  if (!impl.receiver) return;
  sub.deferred = true;
  try {
    impl.updateFilter();
  } catch (const std::system_error& e) {
    throw BusError("LCM bus '" + sub.connection->url() + "': cannot receive: " + e.what());
  }
}

void Node::drainDeferred() {
  // Two guards. This node's: nested in its own deferred handlers, handleDeferred() reads no bus
  // (no handler of another bus runs inside one, review 14 L10) and renews no budget. The
  // receiver's: nested in a deferred handler of another node on the same connection, that
  // receiver reads nothing (UdpmReceiver::receive): its buffers hold the batch being handled.
  if (draining_) return;
  draining_ = true;
  const ClearOnExit done{draining_};
  // Outside a spin (handleDeferred() between spins) a call has a whole budget of its own.
  if (!spinning_) deferred_budget_ = kMaxMessagesPerSpin;
  for (std::size_t i = 0; i < buses_.size() && deferred_budget_ > 0; ++i) {
    Connection::Impl& impl = *buses_[i]->impl_;
    if (!impl.deferred_receiver || impl.deferred_receiver->fd() < 0) continue;
    const std::int64_t read_before = impl.deferred_receiver->datagrams();
    impl.deferred_receiver->receive(
        deferred_budget_, clock_.monotonicNow(),
        [&impl](std::string_view channel, const void* data, int size) {
          impl.dispatch(channel, data, size, true);
        },
        [this, i](const char* kind, const std::string& text) {
          onBusProblem(static_cast<BusId>(i), kind, text);
        });
    deferred_budget_ -= static_cast<int>(impl.deferred_receiver->datagrams() - read_before);
  }
}

void Node::checkDeclaredInput(const std::string& channel) const {
  if (io_ && !io_->readsChannel(channel)) {
    throw std::logic_error(options_.process + " subscribes to " + channel +
                           ", which its declaration (--print-io) does not list among its inputs");
  }
}

Node::Outlet& Node::outlet(std::string_view channel, int index) {
  // The index is trusted only for the name the table has there (a Channel made by hand with a
  // wrong index must not publish under another channel's seq and statistics).
  const bool indexed = index >= 0 && static_cast<std::size_t>(index) < outlet_by_index_.size() &&
                       kAllChannelNames[static_cast<std::size_t>(index)] == channel;
  if (indexed && outlet_by_index_[static_cast<std::size_t>(index)] >= 0) {
    return outlets_[static_cast<std::size_t>(outlet_by_index_[static_cast<std::size_t>(index)])];
  }
  auto it = std::find_if(outlets_.begin(), outlets_.end(),
                         [&](const Outlet& o) { return o.name == channel; });
  if (it == outlets_.end()) {
    outlets_.push_back(Outlet{.name = std::string(channel)});
    it = outlets_.end() - 1;
  }
  if (indexed)
    outlet_by_index_[static_cast<std::size_t>(index)] = static_cast<int>(it - outlets_.begin());
  return *it;
}

bool Node::declaredOutput(Outlet& out) {
  if (out.declared_for != io_count_) {
    out.declared = !io_ || io_->writesChannel(out.name);
    out.declared_for = io_count_;
  }
  if (out.declared) return true;
  reportError("undeclared_output",
              out.name + ": not among the outputs of " + options_.process + "'s declaration");
  return false;
}

void Node::declareIo(ProcessIo io) {
  // Both ways: every subscription declared, every required input subscribed (on some bus).
  for (const auto& sub : subscriptions_) {
    if (!sub->all && !io.readsChannel(sub->channel)) {
      throw std::logic_error(options_.process + " subscribes to " + sub->channel +
                             ", which its declaration (--print-io) does not list");
    }
  }
  // Optional inputs may be subscribed later, when wanted (the viewer's camera streams).
  for (const ChannelUse& input : io.inputs()) {
    if (!input.required) continue;
    const bool subscribed =
        std::any_of(subscriptions_.begin(), subscriptions_.end(),
                    [&](const auto& sub) { return sub->channel == input.channel; });
    if (!subscribed) {
      throw std::logic_error(options_.process + " declares the input " + input.channel +
                             " but does not subscribe to it");
    }
  }
  io_ = std::move(io);
  ++io_count_;
}

void Node::subscribeAllRaw(
    std::function<void(const std::string& channel, const void* data, int size)> handler,
    BusId bus) {
  subscribeRaw(".*", bus, nullptr, std::move(handler));
}

void Node::stampHeader(const Outlet& out, header_t& header) {
  header.seq = out.next_seq;
  header.robot_id = static_cast<std::int8_t>(options_.robot_id);
  header.publisher_id = publisher_id_;
  header.utime_published = clock_.now();
}

bool Node::publishRaw(Outlet& out, const header_t& header, BusId bus) {
  const int rc = connection(bus).impl_->lcm.publish(out.name, encode_buffer_.data(),
                                                    static_cast<unsigned>(encode_buffer_.size()));
  if (rc != 0) {
    reportError("publish", out.name + ": LCM publish failed (" + std::to_string(rc) + ")");
    return false;
  }
  if (out.status_slot < 0) out.status_slot = status_.slot(out.name, Direction::kOut);
  status_.onPublishedAt(out.status_slot, header.utime, header.utime_published);
  return true;
}

bool Node::publishEncoded(std::string_view channel, const void* data, int size, BusId bus) {
  const int rc =
      connection(bus).impl_->lcm.publish(std::string(channel), data, static_cast<unsigned>(size));
  if (rc != 0) reportError("publish", std::string(channel) + ": LCM publish failed");
  return rc == 0;
}

bool Node::acceptHeader(const std::string& channel, int& slot, const header_t& header) {
  const Utime now = clock_.now();
  // Differences of untrusted int64 stamps can overflow: compare in long double.
  const auto ms = [](long double us) { return static_cast<double>(us / 1000.0L); };
  const long double utime = static_cast<long double>(header.utime);
  const long double published = static_cast<long double>(header.utime_published);
  // The sender's clock: the truth for robot 0, ours for our robot, another robot's (off by an
  // unknown amount) otherwise.
  const bool true_time = header.robot_id == 0;
  const bool other_clock = !true_time && header.robot_id != options_.robot_id;
  const Utime receiver_now = true_time ? toTruth(clock_, now) : now;
  const long double receiver = static_cast<long double>(receiver_now);
  const long double slack = other_clock ? static_cast<long double>(kOtherClockTolerance_us) : 0.0L;
  const auto future = static_cast<long double>(options_.future_tolerance_us);
  if (utime > receiver + future + slack) {
    reject(channel, "future_utime",
           fmt::format("utime {} is {:.0f} ms in the future", header.utime, ms(utime - receiver)));
    return false;
  }
  if (published > receiver + future + slack) {
    reject(channel, "future_utime",
           fmt::format("utime_published {} is {:.0f} ms in the future", header.utime_published,
                       ms(published - receiver)));
    return false;
  }
  if (published < receiver - static_cast<long double>(options_.max_age_us) - slack) {
    reject(channel, "stale",
           fmt::format("utime_published {} is {:.0f} ms old", header.utime_published,
                       ms(receiver - published)));
    return false;
  }
  if (utime > published + future ||
      published - utime > static_cast<long double>(options_.max_latency_us)) {
    reject(channel, "bad_stamps",
           fmt::format("utime_published - utime = {:.0f} ms is outside [{:.0f}, {:.0f}] ms",
                       ms(published - utime), -ms(future),
                       ms(static_cast<long double>(options_.max_latency_us))));
    return false;
  }
  // Every process publishes SERVICE_STATUS: several publishers there are by design.
  const bool one_publisher = channel != channels::kServiceStatus.name;
  const Received received{.robot_id = header.robot_id,
                          .publisher_id = header.publisher_id,
                          .seq = header.seq,
                          .utime = header.utime,
                          .utime_published = header.utime_published};
  if (one_publisher) {
    if (slot < 0) slot = status_.slot(channel, Direction::kIn);
    status_.onReceivedAt(slot, received, receiver_now, true);
  } else {
    status_.onReceived(channel, header.robot_id, header.seq, header.utime, header.utime_published,
                       false);
  }
  return true;
}

void Node::reject(const std::string& channel, const std::string& kind, const std::string& text) {
  status_.onRejected(channel);
  reportError(kind, channel + ": " + text);
}

void Node::reportError(const std::string& kind, const std::string& text) {
  status_.onError(kind, text, clock_.now());
  // Log the first few of each kind, then every 100th, so a flood stays readable.
  auto it = std::find_if(logged_errors_.begin(), logged_errors_.end(),
                         [&](const auto& p) { return p.first == kind; });
  if (it == logged_errors_.end()) {
    logged_errors_.emplace_back(kind, 0);
    it = logged_errors_.end() - 1;
  }
  const std::int64_t n = ++it->second;
  if (n <= 5 || n % 100 == 0) {
    spdlog::warn("[{}] {} (#{} of this kind): {}", options_.process, kind, n, text);
  }
}

void Node::setMetric(const std::string& name, double value) {
  status_.setMetric(name, value);
}

void Node::timed(const std::function<void()>& fn) {
  // Processing time is a measurement of this machine, not part of the time model: steady clock.
  const auto start = std::chrono::steady_clock::now();
  try {
    fn();
  } catch (const std::exception& e) {
    // A handler or timer that throws is a bug, but one bad message must not end the process.
    reportError("exception", e.what());
  }
  const auto end = std::chrono::steady_clock::now();
  status_.onProcessing(std::chrono::duration<double, std::milli>(end - start).count());
}

Node::TimerId Node::addTimer(Utime next, Utime period, std::function<void()> fn) {
  const TimerId id = next_timer_id_++;
  timers_.push_back(Timer{next, period, std::move(fn), id});
  return id;
}

Node::TimerId Node::every(Utime period_us, std::function<void()> fn) {
  if (period_us <= 0) throw std::invalid_argument("timer period must be positive");
  return addTimer(clock_.monotonicNow() + period_us, period_us, std::move(fn));
}

Node::TimerId Node::at(Utime when, std::function<void()> fn) {
  return addTimer(clock_.monotonicNow() + (when - clock_.now()), 0, std::move(fn));
}

Node::TimerId Node::after(Utime delay_us, std::function<void()> fn) {
  if (delay_us < 0) throw std::invalid_argument("timer delay must not be negative");
  return addTimer(clock_.monotonicNow() + delay_us, 0, std::move(fn));
}

Node::Timer* Node::findTimer(TimerId id) {
  auto it = std::find_if(timers_.begin(), timers_.end(),
                         [id](const Timer& t) { return t.id == id && t.period >= 0; });
  return it == timers_.end() ? nullptr : &*it;
}

bool Node::moveTimer(TimerId id, Utime delay_us) {
  if (delay_us < 0) throw std::invalid_argument("timer delay must not be negative");
  Timer* timer = findTimer(id);
  if (!timer) return false;
  timer->next = clock_.monotonicNow() + delay_us;
  return true;
}

bool Node::cancelTimer(TimerId id) {
  Timer* timer = findTimer(id);
  if (!timer) return false;
  // Not erased here: fireTimers() may be walking the vector.
  timer->period = -1;
  timer->next = std::numeric_limits<Utime>::max();
  return true;
}

Node::WatchId Node::watchFd(int fd, std::function<void()> on_ready) {
  if (fd < 0) throw std::invalid_argument("cannot watch fd " + std::to_string(fd));
  const WatchId id = next_watch_id_++;
  watches_.push_back(Watch{id, fd, std::move(on_ready)});
  return id;
}

void Node::unwatchFd(WatchId id) {
  std::erase_if(watches_, [id](const Watch& w) { return w.id == id; });
}

void Node::fireTimers() {
  const Utime now = clock_.monotonicNow();
  // Deferred messages before any timer or status that is due (they may use what those carry).
  const bool status_due = options_.status_period_us > 0 && now >= next_status_;
  if (status_due || std::any_of(timers_.begin(), timers_.end(),
                                [now](const Timer& t) { return t.next <= now; })) {
    drainDeferred();
  }
  // Index loop: a timer callback may add timers.
  for (std::size_t i = 0; i < timers_.size(); ++i) {
    if (timers_[i].next > now || timers_[i].period < 0) continue;
    auto fn = timers_[i].fn;
    if (timers_[i].period > 0) {
      timers_[i].next += timers_[i].period;
      // Far behind (e.g. a stalled process): skip missed ticks instead of firing a burst.
      if (timers_[i].next <= now) timers_[i].next = now + timers_[i].period;
    } else {
      timers_[i].period = -1;  // fired one-shot, removed below
    }
    timed(fn);
  }
  std::erase_if(timers_, [](const Timer& t) { return t.period < 0; });
  if (options_.status_period_us > 0 && now >= next_status_) {
    publishStatus();
    next_status_ = now + options_.status_period_us;
  }
  // READY=1 once, WATCHDOG=1 when due (under a systemd unit): from the loop itself.
  systemd::onLoop(now);
}

int Node::msUntilNextTimer(int max_ms) const {
  const Utime now = clock_.monotonicNow();
  Utime next = now + static_cast<Utime>(max_ms) * kMicrosPerMilli;
  if (options_.status_period_us > 0) next = std::min(next, next_status_);
  if (const Utime ping = systemd::nextPingDue(); ping > 0) next = std::min(next, ping);
  for (const auto& t : timers_)
    if (t.period >= 0) next = std::min(next, t.next);
  // Round up: waking a little late fires the timer; waking early would only spin again.
  return static_cast<int>(std::max<Utime>(0, next - now + kMicrosPerMilli - 1) / kMicrosPerMilli);
}

void Node::publishStatus() {
  for (const auto& fn : before_status_)
    timed(fn);
  service_status_t s = status_.takeStatus(clock_.now());
  systemd::notifyStatus(s.state == service_status_t::STATE_OK     ? "ok"
                        : s.state == service_status_t::STATE_WARN ? "WARN " + s.state_reason
                                                                  : "ERROR " + s.state_reason);
  publish(channels::kServiceStatus, s);
}

int Node::spinOnce(int timeout_ms) {
  spinning_ = true;
  const ClearOnExit done{spinning_};
  deferred_budget_ = kMaxMessagesPerSpin;
  // Buses first, then the watched fds, each remembered by id: a callback may unwatch any. The
  // vectors are members, reused: a spin allocates nothing.
  std::vector<pollfd>& fds = poll_fds_;
  std::vector<WatchId>& watch_ids = poll_watch_ids_;
  fds.clear();
  watch_ids.clear();
  // A udpm bus nobody here reads has no socket yet (-1: poll() skips it).
  for (const auto& b : buses_)
    fds.push_back(pollfd{b->impl_->waitFd(), POLLIN, 0});
  for (const auto& w : watches_) {
    fds.push_back(pollfd{w.fd, POLLIN, 0});
    watch_ids.push_back(w.id);
  }
  int handled = 0;
  const int ready = ::poll(fds.data(), fds.size(), std::max(0, timeout_ms));
  if (ready > 0) {
    // What was deferred came first: the deferred sockets are read after each batch of a bus's
    // datagrams is read and before it is handled, so every deferred message that arrived before
    // one of the batch is handled before it (read once before the bus, a deferred message that
    // came between the two reads would go after the batch's newer messages).
    const UdpmReceiver::BatchFn drain = [this] { drainDeferred(); };
    for (std::size_t i = 0; i < buses_.size(); ++i) {
      if (!(fds[i].revents & POLLIN)) continue;
      Connection::Impl& impl = *buses_[i]->impl_;
      // Drain what is queued on this bus, bounded so timers and status still run under a flood.
      if (impl.receiver) {
        handled += impl.receiver->receive(
            kMaxMessagesPerSpin, clock_.monotonicNow(),
            [&impl](std::string_view channel, const void* data, int size) {
              impl.dispatch(channel, data, size);
            },
            [this, i](const char* kind, const std::string& text) {
              onBusProblem(static_cast<BusId>(i), kind, text);
            },
            impl.deferred_receiver ? &drain : nullptr);
        continue;
      }
      for (int n = 0; n < kMaxMessagesPerSpin && impl.lcm.handleTimeout(0) > 0; ++n) {
        ++handled;
      }
    }
    for (std::size_t k = 0; k < watch_ids.size(); ++k) {
      const short revents = fds[buses_.size() + k].revents;
      if (revents == 0) continue;
      auto it = std::find_if(watches_.begin(), watches_.end(),
                             [&](const Watch& w) { return w.id == watch_ids[k]; });
      if (it == watches_.end()) continue;  // unwatched by an earlier callback
      if (revents & POLLNVAL) {
        reportError("watch_fd", "fd " + std::to_string(it->fd) + " is not open; no longer watched");
        watches_.erase(it);
        continue;
      }
      // A copy: the callback may unwatch itself.
      auto on_ready = it->on_ready;
      timed(on_ready);
    }
  }
  fireTimers();
  return handled;
}

void Node::onBusProblem(BusId bus, const char* kind, const std::string& text) {
  reportError(kind, text + " (bus " + url(bus) + ")");
}

bool Node::stopRequested() const {
  return stop_requested_ || stopSignalReceived();
}

int Node::run() {
  installStopSignals();
  // Signals interrupt poll(); the cap only bounds how late a stop request set by another
  // thread is noticed.
  constexpr int kMaxWaitMs = 100;
  while (!stopRequested()) {
    spinOnce(msUntilNextTimer(kMaxWaitMs));
  }
  spdlog::info("[{}] stopping", options_.process);
  systemd::notifyStopping();
  return 0;
}

}  // namespace fieldline::bus
