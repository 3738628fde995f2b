#include "common/bus/node.hpp"

#include <algorithm>
#include <chrono>
#include <csignal>
#include <random>

#include <fmt/format.h>
#include <poll.h>
#include <spdlog/spdlog.h>
#include <lcm/lcm-cpp.hpp>

#include "common/bus/frames_bus.hpp"
#include "common/bus/systemd_notify.hpp"
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
struct Connection::Impl {
  lcm::LCM lcm;
  // Something subscribed here: the loop waits on it. A bus only published to is never asked for
  // its file descriptor, which would make LCM open a receiving socket that copies (and drops)
  // everything on the port.
  bool receiving = false;
  // The frames bus (framesBusUrl), opened on first use; null when frames share this bus.
  std::shared_ptr<Connection> frames;
  bool frames_opened = false;
  explicit Impl(const std::string& url) : lcm(url) {}

  // The connection `channel` travels on from `c`: c itself, or its frames bus for camera frames.
  static Connection& forChannel(Connection& c, std::string_view channel) {
    return travelsOnFramesBus(channel) ? framesOf(c) : c;
  }
  static Connection& framesOf(Connection& c) {
    Impl& impl = *c.impl_;
    if (!impl.frames_opened) {
      const std::string url = framesBusUrl(c.url());
      if (url != c.url()) impl.frames = Connection::open(url);
      impl.frames_opened = true;
    }
    return impl.frames ? *impl.frames : c;
  }
  static lcm::Subscription* subscribe(Connection& c, const std::string& channel,
                                      void (*dispatch)(const lcm::ReceiveBuffer*,
                                                       const std::string&, void*),
                                      void* context) {
    c.impl_->receiving = true;
    lcm::Subscription* s = c.impl_->lcm.subscribeFunction(channel, dispatch, context);
    // Big messages (images) come in bursts; let a slow handler fall behind a little, not
    // forever.
    if (s) s->setQueueCapacity(60);
    return s;
  }
};

Connection::Connection(std::string url)
    : url_(std::move(url)), impl_(std::make_unique<Impl>(url_)) {}
Connection::~Connection() = default;

std::shared_ptr<Connection> Connection::open(const std::string& url) {
  std::shared_ptr<Connection> c(new Connection(url));
  if (!c->impl_->lcm.good()) throw BusError(remedyFor(url));
  return c;
}

// ---------------------------------------------------------------------------------------------
struct Node::Subscription {
  Node* node;
  std::string channel;
  RawHandler handler;
  // Set instead of handler for subscribeAllRaw: also gets the channel name.
  std::function<void(const std::string&, const void*, int)> all;
  Connection* connection = nullptr;
  lcm::Subscription* lcm_subscription = nullptr;
};

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

void Node::subscribeRaw(const std::string& channel, BusId bus, RawHandler handler) {
  auto sub = std::make_unique<Subscription>();
  sub->node = this;
  sub->channel = channel;
  sub->handler = std::move(handler);
  sub->connection = &Connection::Impl::forChannel(connection(bus), channel);
  sub->lcm_subscription = Connection::Impl::subscribe(*sub->connection, channel, &dispatchRaw,
                                                      static_cast<void*>(sub.get()));
  subscriptions_.push_back(std::move(sub));
}

void Node::subscribeAllRaw(
    std::function<void(const std::string& channel, const void* data, int size)> handler,
    BusId bus) {
  // The bus and, where frames have a bus of their own, that one too (frames_bus.hpp).
  Connection& primary = connection(bus);
  Connection& frames = Connection::Impl::framesOf(primary);
  if (&frames != &primary) {
    auto sub = std::make_unique<Subscription>();
    sub->node = this;
    sub->channel = ".*";
    sub->all = handler;
    sub->connection = &frames;
    sub->lcm_subscription =
        Connection::Impl::subscribe(frames, ".*", &dispatchRaw, static_cast<void*>(sub.get()));
    subscriptions_.push_back(std::move(sub));
  }
  subscribeRaw(".*", bus, nullptr);
  subscriptions_.back()->all = std::move(handler);
}

std::int64_t& Node::nextSeq(const std::string& channel) {
  auto it = std::find_if(next_seq_.begin(), next_seq_.end(),
                         [&](const auto& p) { return p.first == channel; });
  if (it == next_seq_.end()) {
    next_seq_.emplace_back(channel, 0);
    it = next_seq_.end() - 1;
  }
  return it->second;
}

void Node::stampHeader(const std::string& channel, header_t& header) {
  header.seq = nextSeq(channel);
  header.robot_id = static_cast<std::int8_t>(options_.robot_id);
  header.publisher_id = publisher_id_;
  header.utime_published = clock_.now();
}

bool Node::publishRaw(const std::string& channel, const header_t& header, BusId bus) {
  const int rc = Connection::Impl::forChannel(connection(bus), channel)
                     .impl_->lcm.publish(channel, encode_buffer_.data(),
                                         static_cast<unsigned>(encode_buffer_.size()));
  if (rc != 0) {
    reportError("publish", channel + ": LCM publish failed (" + std::to_string(rc) + ")");
    return false;
  }
  status_.onPublished(channel, header.utime, header.utime_published);
  return true;
}

bool Node::publishEncoded(std::string_view channel, const void* data, int size, BusId bus) {
  const int rc = Connection::Impl::forChannel(connection(bus), channel)
                     .impl_->lcm.publish(std::string(channel), data, static_cast<unsigned>(size));
  if (rc != 0) reportError("publish", std::string(channel) + ": LCM publish failed");
  return rc == 0;
}

bool Node::acceptHeader(const std::string& channel, const header_t& header) {
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
    status_.onReceived(channel, received, receiver_now, true);
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

void Node::every(Utime period_us, std::function<void()> fn) {
  if (period_us <= 0) throw std::invalid_argument("timer period must be positive");
  timers_.push_back(Timer{clock_.monotonicNow() + period_us, period_us, std::move(fn)});
}

void Node::at(Utime when, std::function<void()> fn) {
  timers_.push_back(Timer{clock_.monotonicNow() + (when - clock_.now()), 0, std::move(fn)});
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
  // Index loop: a timer callback may add timers.
  for (std::size_t i = 0; i < timers_.size(); ++i) {
    if (timers_[i].next > now) continue;
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
    next = std::min(next, t.next);
  // Round up: waking a little late fires the timer; waking early would only spin again.
  return static_cast<int>(std::max<Utime>(0, next - now + kMicrosPerMilli - 1) / kMicrosPerMilli);
}

void Node::publishStatus() {
  service_status_t s = status_.takeStatus(clock_.now());
  systemd::notifyStatus(s.state == service_status_t::STATE_OK     ? "ok"
                        : s.state == service_status_t::STATE_WARN ? "WARN " + s.state_reason
                                                                  : "ERROR " + s.state_reason);
  publish(channels::kServiceStatus, s);
}

int Node::spinOnce(int timeout_ms) {
  // Buses with subscriptions (and their frames buses) first, then the watched fds, each
  // remembered by id: a callback may unwatch any.
  std::vector<pollfd> fds;
  std::vector<Connection*> polled;
  std::vector<WatchId> watch_ids;
  fds.reserve(2 * buses_.size() + watches_.size());
  auto addPolled = [&](Connection& c) {
    if (!c.impl_->receiving) return;
    polled.push_back(&c);
    fds.push_back(pollfd{c.impl_->lcm.getFileno(), POLLIN, 0});
  };
  for (const auto& b : buses_) {
    addPolled(*b);
    if (b->impl_->frames) addPolled(*b->impl_->frames);
  }
  for (const auto& w : watches_) {
    fds.push_back(pollfd{w.fd, POLLIN, 0});
    watch_ids.push_back(w.id);
  }
  int handled = 0;
  const int ready = ::poll(fds.data(), fds.size(), std::max(0, timeout_ms));
  if (ready > 0) {
    for (std::size_t i = 0; i < polled.size(); ++i) {
      if (fds[i].revents & POLLIN) {
        // Drain what is queued on this bus, bounded so timers and status still run under a flood.
        for (int n = 0; n < kMaxMessagesPerSpin && polled[i]->impl_->lcm.handleTimeout(0) > 0;
             ++n) {
          ++handled;
        }
      }
    }
    for (std::size_t k = 0; k < watch_ids.size(); ++k) {
      const short revents = fds[polled.size() + k].revents;
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
