#include "tools/viewer/viewer_node.hpp"

#include <algorithm>
#include <stdexcept>
#include <thread>

#include <spdlog/spdlog.h>

namespace fieldline::viewer {

namespace {

// How often the primary node looks for pages (an atomic read; a page waits at most this long
// for the buses to open).
constexpr Utime kClientCheckUs = 200 * kMicrosPerMilli;
// The watching node's longest wait in poll(): how late it notices a stop request.
constexpr int kWatchSpinMs = 100;

template <typename Msg>
void keepLatest(bus::Node& node, bus::Channel<Msg> channel, bus::BusId bus,
                std::optional<Received<Msg>>& slot) {
  node.subscribe(
      channel,
      [&node, &slot](const Msg& m) {
        slot = Received<Msg>{m, node.now()};
      },
      bus);
}

void keepStatuses(bus::Node& node, bus::BusId bus, BusView& view) {
  node.subscribe(
      bus::channels::kServiceStatus,
      [&node, &view](const service_status_t& m) {
        view.statuses[{m.process, m.header.robot_id}] = {m, node.now()};
      },
      bus);
}

}  // namespace

std::string viewerPrimaryUrl(const ViewerOptions& options) {
  if (!options.bus_url.empty()) return options.bus_url;
  if (options.sim) {
    return options.sim_bus_url.empty() ? bus::simBusUrl(options.address) : options.sim_bus_url;
  }
  if (options.robots.empty()) throw std::invalid_argument("viewer: no robot to watch");
  return bus::robotBusUrl(options.robots.front(), options.address);
}

// The buses of a watched team: a bus::Node of its own (same primary URL and limits, no
// SERVICE_STATUS) spun on its own thread, with the team's picture and the camera view; gone
// (buses closed) when destroyed.
class ViewerNode::Watch {
 public:
  Watch(const bus::Node& primary, const ViewerOptions& options, WebServer& server,
        Counters& counters)
      : options_(options),
        server_(server),
        counters_(counters),
        node_(watchOptions(primary.options()), primary.clock()),
        team_(options_.robots),
        camera_(options_.camera) {
    const std::string primary_url = node_.url();
    const auto busId = [&](const std::string& url) {
      return url == primary_url ? bus::kPrimaryBus : node_.addBus(url);
    };
    if (options_.sim) {
      BusView& sim = team_.bus(0);
      sim.url =
          options_.sim_bus_url.empty() ? bus::simBusUrl(options_.address) : options_.sim_bus_url;
      const bus::BusId id = busId(sim.url);
      node_.subscribe(
          bus::channels::kSimWorld,
          [this](const world_state_t& m) { team_.setSimWorld(m, node_.now()); }, id);
      keepStatuses(node_, id, sim);
    }
    for (int robot : options_.robots) {
      BusView& view = team_.bus(robot);
      view.url = bus::robotBusUrl(robot, options_.address);
      const bus::BusId id = busId(view.url);
      robot_bus_.push_back(id);
      keepLatest(node_, bus::channels::kRobotState, id, view.robot_state);
      keepLatest(node_, bus::channels::kBallState, id, view.ball_state);
      keepLatest(node_, bus::channels::kTeamState, id, view.team_state);
      node_.subscribe(
          bus::channels::kVisionLines,
          [this, robot, &view](const line_contours_t& m) {
            view.vision_lines = Received<line_contours_t>{m, node_.now()};
            camera_.onLines(robot, m, node_.now());
          },
          id);
      keepStatuses(node_, id, view);
    }
    node_.every(static_cast<Utime>(1e6 / options_.rate_hz), [this] { tick(); });
    node_.declareIo(viewerIo(options_));
    thread_ = std::thread([this] {
      while (!stop_ && !bus::stopSignalReceived())
        node_.spinOnce(kWatchSpinMs);
    });
  }

  ~Watch() {
    stop_ = true;
    thread_.join();
  }

 private:
  static bus::NodeOptions watchOptions(bus::NodeOptions options) {
    options.status_period_us = 0;
    return options;
  }

  void tick() {
    const Utime now = node_.now();
    const int wanted = server_.cameraWanted(options_.camera_wanted_s);
    const bool shown =
        std::find(options_.robots.begin(), options_.robots.end(), wanted) != options_.robots.end();
    camera_.select(shown ? wanted : 0);
    if (shown) watchCamera(wanted);
    if (auto doc = camera_.update(now)) server_.publishCamera(wanted, std::move(*doc));
    server_.publish(team_.toJson(now, kStatusStaleUs));
    ++counters_.states_pushed;
    counters_.camera_robot = camera_.selected();
    counters_.camera_frames_encoded = camera_.framesEncoded();
    if (camera_.framesRefused() > counters_.camera_frames_refused) {
      std::lock_guard lock(counters_.problem_mutex);
      counters_.last_camera_problem = camera_.lastProblem();
      counters_.camera_frames_refused = camera_.framesRefused();
    }
  }

  void watchCamera(int robot) {
    const auto at = std::find(options_.robots.begin(), options_.robots.end(), robot);
    if (at == options_.robots.end() || camera_subscribed_.count(robot)) return;
    camera_subscribed_.insert(robot);
    const bus::BusId id = robot_bus_[static_cast<std::size_t>(at - options_.robots.begin())];
    // bus::Node has no unsubscribe: once watched in this session, a robot's frames keep arriving
    // (until the page leaves and the buses close) and are dropped by CameraView unless it is the
    // selected one.
    node_.subscribe(
        bus::channels::kCameraImage, [this, robot](const image_t& m) { camera_.onImage(robot, m); },
        id);
    // On another machine than the robot only the reduced stream arrives (docs/launch.md,
    // "Watching from a laptop").
    node_.subscribe(
        bus::channels::kCameraPreview,
        [this, robot](const image_t& m) { camera_.onPreview(robot, m); }, id);
    node_.subscribe(
        bus::channels::kVisionBall,
        [this, robot](const ball_observation_t& m) { camera_.onBall(robot, m); }, id);
  }

  const ViewerOptions& options_;
  WebServer& server_;
  Counters& counters_;
  bus::Node node_;
  TeamView team_;
  CameraView camera_;
  std::vector<bus::BusId> robot_bus_;  // by index in options_.robots
  std::set<int> camera_subscribed_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

ViewerNode::ViewerNode(bus::Node& node, ViewerOptions options, WebServer& server)
    : node_(node), options_(std::move(options)), server_(server) {
  // Nobody watches yet: the page gets an empty picture until the buses are open.
  server_.publish(TeamView(options_.robots).toJson(node_.now(), kStatusStaleUs));
  node_.every(kClientCheckUs, [this] { checkClients(); });
  node_.declareIo(viewerIo(options_));
  checkClients();
}

ViewerNode::~ViewerNode() = default;

void ViewerNode::checkClients() {
  const Utime now = node_.clock().monotonicNow();
  // A WebSocket client now, or a request since the last check (a GET, a page loading).
  const bool page = server_.watched(2e-6 * static_cast<double>(kClientCheckUs));
  if (page) last_watched_ = now;
  if (page && !watch_) {
    watch_ = std::make_unique<Watch>(node_, options_, server_, counters_);
    ++watch_sessions_;
    spdlog::info("a page is watching: the robots' buses are open");
  } else if (!page && watch_ &&
             static_cast<double>(now - last_watched_) * 1e-6 > options_.idle_after_s) {
    watch_.reset();
    server_.publish(TeamView(options_.robots).toJson(node_.now(), kStatusStaleUs));
    spdlog::info("no page for {:.0f} s: the robots' buses are closed, nothing is read",
                 options_.idle_after_s);
  }
  node_.setMetric("watching", watch_ ? 1.0 : 0.0);
  node_.setMetric("watch_sessions", static_cast<double>(watch_sessions_));
  node_.setMetric("web_socket_clients", server_.webSocketClients());
  node_.setMetric("states_pushed", static_cast<double>(counters_.states_pushed.load()));
  node_.setMetric("methods_refused", static_cast<double>(server_.methodsRefused()));
  node_.setMetric("connections_refused", static_cast<double>(server_.connectionsRefused()));
  node_.setMetric("camera_robot", counters_.camera_robot.load());
  node_.setMetric("camera_frames_encoded",
                  static_cast<double>(counters_.camera_frames_encoded.load()));
  if (counters_.camera_frames_refused > reported_refused_) {
    reported_refused_ = counters_.camera_frames_refused;
    std::lock_guard lock(counters_.problem_mutex);
    node_.reportError("camera_frame", counters_.last_camera_problem);
  }
}

bus::ProcessIo viewerIo(const ViewerOptions& options) {
  bus::ProcessIo io("viewer");
  if (options.sim) io.readsIfPresent(bus::channels::kSimWorld);
  if (!options.robots.empty()) {
    io.readsFromEveryRobot(bus::channels::kRobotState)
        .readsFromEveryRobot(bus::channels::kBallState)
        .readsFromEveryRobot(bus::channels::kTeamState)
        .readsFromEveryRobot(bus::channels::kVisionLines)
        .readsFromEveryRobot(bus::channels::kVisionBall)
        .readsFromEveryRobot(bus::channels::kCameraImage)
        .readsFromEveryRobot(bus::channels::kCameraPreview);
  }
  if (options.sim || !options.robots.empty()) {
    io.readsFromEveryRobot(bus::channels::kServiceStatus);
  }
  return io;
}

}  // namespace fieldline::viewer
