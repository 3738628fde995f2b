#include "tools/viewer/viewer_cli.hpp"

#include <algorithm>
#include <filesystem>

namespace fieldline::viewer {

ViewerCommandLine::ViewerCommandLine(cli::App& app, const std::string& web_dir)
    : web_dir_(web_dir) {
  port_ = web.port;
  common.robot = 0;
  common.addTo(app);
  app.add_option("--address", web.address, "Address to serve on (0.0.0.0: every interface)")
      ->capture_default_str();
  app.add_option("--port", port_, "TCP port to serve on (0: any free one, printed)")
      ->check(cli::Range(0, 65535))
      ->capture_default_str();
  app.add_option("--robots", viewer.robots, "Robots whose buses to watch")
      ->delimiter(',')
      ->check(cli::Range(1, 6))
      ->capture_default_str();
  app.add_flag("--no-sim", no_sim_, "Do not watch the simulator's bus (on a real team)");
  app.add_option("--field", field, "Field preset name or YAML file to draw")->capture_default_str();
  app.add_option("--rate", viewer.rate_hz, "WebSocket updates per second")
      ->check(cli::Range(1.0, 100.0))
      ->capture_default_str();
  app.add_option("--camera-rate", viewer.camera.max_rate_hz,
                 "Camera view: JPEGs of the selected robot's camera per second at most")
      ->check(cli::Range(0.5, 30.0))
      ->capture_default_str();
  app.add_option("--web-dir", web_dir_, "Directory with index.html and viewer.js")
      ->check(cli::ExistingDirectory)
      ->capture_default_str();
  app.add_option("--log", log,
                 "Play a recording instead of watching the buses: a recording's directory "
                 "(fieldline-record, scripts/demo --record) or one LCM log; the page gets a "
                 "timeline (play, pause, speed, scrubbing) and plots over time")
      ->check(cli::ExistingPath);
  app.add_flag("--play", play, "--log: start playing at once");
  app.add_option("--speed", speed, "--log: playback speed")
      ->check(cli::Range(0.01, 100.0))
      ->capture_default_str();
  app.add_flag("--replay-bus", replay_bus,
               "The buses carry a replay (lcm-logplayer, fieldline-replay's output played back): "
               "messages are shown however old their stamps are");
  app.add_option("--base-port", viewer.address.base_port,
                 "Port of the simulator's bus; robot N's is this + N")
      ->check(cli::Range(1, 65535 - 6))
      ->capture_default_str();
}

std::optional<std::string> ViewerCommandLine::finish() {
  std::sort(viewer.robots.begin(), viewer.robots.end());
  if (std::adjacent_find(viewer.robots.begin(), viewer.robots.end()) != viewer.robots.end()) {
    return "--robots: a robot is listed twice";
  }
  if (!std::filesystem::is_regular_file(std::filesystem::path(web_dir_) / "index.html")) {
    return "the viewer's page (index.html) is not in " + web_dir_ +
           ": give its folder with --web-dir (installed: <prefix>/share/fieldline/web; source: "
           "tools/viewer/web)";
  }
  web.port = static_cast<unsigned short>(port_);
  web.web_dir = web_dir_;
  web.push_period_s = 1.0 / viewer.rate_hz;
  viewer.sim = !no_sim_;
  viewer.bus_url = common.bus_url;
  viewer.sim_bus_url = common.sim_bus_url;
  return std::nullopt;
}

}  // namespace fieldline::viewer
