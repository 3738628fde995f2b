#include "tools/viewer/viewer_node.hpp"

#include <algorithm>
#include <stdexcept>

namespace fieldline::viewer {

namespace {

// SERVICE_STATUS comes every second: three missed ones mean the process is gone or hung.
constexpr Utime kStatusStaleUs = 3 * kMicrosPerSecond;

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

ViewerNode::ViewerNode(bus::Node& node, ViewerOptions options, WebServer& server)
    : node_(node),
      options_(std::move(options)),
      server_(server),
      team_(options_.robots),
      camera_(options_.camera) {
  const std::string primary = viewerPrimaryUrl(options_);
  const auto busId = [&](const std::string& url) {
    return url == primary ? bus::kPrimaryBus : node_.addBus(url);
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

void ViewerNode::watchCamera(int robot) {
  const auto at = std::find(options_.robots.begin(), options_.robots.end(), robot);
  if (at == options_.robots.end() || camera_subscribed_.count(robot)) return;
  camera_subscribed_.insert(robot);
  const bus::BusId id = robot_bus_[static_cast<std::size_t>(at - options_.robots.begin())];
  // bus::Node has no unsubscribe: once watched, a robot's frames keep arriving and are dropped
  // by CameraView unless it is the selected one.
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

void ViewerNode::tick() {
  const Utime now = node_.now();
  const int wanted = server_.cameraWanted(options_.camera_wanted_s);
  const bool watched =
      std::find(options_.robots.begin(), options_.robots.end(), wanted) != options_.robots.end();
  camera_.select(watched ? wanted : 0);
  if (watched) watchCamera(wanted);
  if (auto doc = camera_.update(now)) server_.publishCamera(wanted, std::move(*doc));

  server_.publish(team_.toJson(now, kStatusStaleUs));
  node_.setMetric("web_socket_clients", server_.webSocketClients());
  node_.setMetric("methods_refused", static_cast<double>(server_.methodsRefused()));
  node_.setMetric("connections_refused", static_cast<double>(server_.connectionsRefused()));
  node_.setMetric("camera_robot", camera_.selected());
  node_.setMetric("camera_frames_encoded", static_cast<double>(camera_.framesEncoded()));
  if (camera_.framesRefused() > reported_refused_) {
    reported_refused_ = camera_.framesRefused();
    node_.reportError("camera_frame", camera_.lastProblem());
  }
}

}  // namespace fieldline::viewer
