// The viewer's bus side: subscribes to every watched robot's bus and the simulator's, keeps the
// team's picture (TeamView) and the selected robot's camera view (CameraView), and hands both to
// the web server at the push rate.
//
// Only while someone watches: the robots' buses are opened when a page connects (a WebSocket
// client, or a GET within ViewerOptions::idle_after_s) and closed again idle_after_s after the
// last one left, so an unwatched viewer receives, decodes and serializes nothing; its
// SERVICE_STATUS says so (metric watching 0, web_clients 0). While watched, a second bus::Node
// on a thread of its own reads the buses (no SERVICE_STATUS of its own: the primary node reports
// for both). The camera's images are subscribed for a robot only once a
// page asks for its camera (GET /camera.json?robot=N): CAMERA_IMAGE on the robot's own machine,
// CAMERA_PREVIEW from another one (the full frames stay on the robot); decoded frames of any other
// robot are dropped at once; JPEGs are made at CameraViewOptions::max_rate_hz at most.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
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
  // The buses are closed this long after the last page left (a reload keeps them open).
  double idle_after_s = 10.0;
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
  ~ViewerNode();
  ViewerNode(const ViewerNode&) = delete;
  ViewerNode& operator=(const ViewerNode&) = delete;

  // True while the robots' buses are open (someone watches).
  bool watching() const { return watch_ != nullptr; }

  // What the watching thread tells the primary node's status (atomics: two threads).
  struct Counters {
    std::atomic<std::int64_t> states_pushed{0};
    std::atomic<int> camera_robot{0};
    std::atomic<std::int64_t> camera_frames_encoded{0};
    std::atomic<std::int64_t> camera_frames_refused{0};
    std::mutex problem_mutex;
    std::string last_camera_problem;
  };

 private:
  class Watch;
  // Opens or closes the buses as pages come and go; reports the status metrics.
  void checkClients();

  bus::Node& node_;
  ViewerOptions options_;
  WebServer& server_;
  Counters counters_;
  std::unique_ptr<Watch> watch_;
  Utime last_watched_ = 0;
  std::int64_t watch_sessions_ = 0;
  std::int64_t reported_refused_ = 0;
};

}  // namespace fieldline::viewer
