// The viewer's bus side: subscribes to every watched robot's bus and the simulator's, keeps the
// team's picture (TeamView) and the selected robot's camera view (CameraView), and hands both to
// the web server at the push rate. The camera's images are subscribed for a robot only once a
// page asks for its camera (GET /camera.json?robot=N): CAMERA_IMAGE on the robot's own machine,
// CAMERA_PREVIEW from another one (the full frames stay on the robot); decoded frames of any other
// robot are dropped at once; JPEGs are made at CameraViewOptions::max_rate_hz at most.
#pragma once

#include <set>
#include <string>
#include <vector>

#include "common/bus/node.hpp"
#include "common/bus/urls.hpp"
#include "tools/viewer/camera_view.hpp"
#include "tools/viewer/team_view.hpp"
#include "tools/viewer/web_server.hpp"

namespace fieldline::viewer {

struct ViewerOptions {
  std::vector<int> robots{1, 2, 3, 4, 5, 6};
  // Watch the simulator's bus (SIM_WORLD and its processes); false on a real team.
  bool sim = true;
  bus::BusAddress address;
  // Overrides of the primary and the simulator's bus URL (fieldline-launch passes them).
  std::string bus_url;
  std::string sim_bus_url;
  // State documents per second.
  double rate_hz = 20.0;
  // A page that asked for no camera frame for this long no longer wants one.
  double camera_wanted_s = 2.0;
  CameraViewOptions camera;
};

// The primary bus: the simulator's (the viewer's SERVICE_STATUS goes there), or on a real team
// the first robot's, unless bus_url says otherwise.
std::string viewerPrimaryUrl(const ViewerOptions& options);

// What the viewer reads: every watched robot's estimates, vision, statuses and camera streams
// (subscribed when a page shows them), and the simulator's truth (fieldline-viewer --print-io).
bus::ProcessIo viewerIo(const ViewerOptions& options);

class ViewerNode {
 public:
  // `node`'s primary bus must be viewerPrimaryUrl(options).
  ViewerNode(bus::Node& node, ViewerOptions options, WebServer& server);

  const TeamView& team() const { return team_; }

 private:
  void tick();
  void watchCamera(int robot);

  bus::Node& node_;
  ViewerOptions options_;
  WebServer& server_;
  TeamView team_;
  CameraView camera_;
  std::vector<bus::BusId> robot_bus_;  // by index in options_.robots
  std::set<int> camera_subscribed_;
  std::int64_t reported_refused_ = 0;
};

}  // namespace fieldline::viewer
