// fieldline-viewer's command line: the options of the web server, the bus side and the field.
#pragma once

#include <optional>
#include <string>

#include "common/bus/cli.hpp"
#include "common/cli/cli.hpp"
#include "tools/viewer/viewer_node.hpp"
#include "tools/viewer/web_server.hpp"

namespace fieldline::viewer {

struct ViewerCommandLine {
  WebServerOptions web;
  ViewerOptions viewer;
  std::string field = "msl";
  bus::CommonOptions common;
  // --log: play this recording (a directory or a log) instead of watching the buses.
  std::string log;
  bool play = false;
  double speed = 1.0;
  // --replay-bus: the buses carry a replay (lcm-logplayer, a replay's output): old stamps are not
  // stale and the robots' clocks may be anywhere.
  bool replay_bus = false;

  // `web_dir`: where the page is served from unless --web-dir says otherwise.
  ViewerCommandLine(cli::App& app, const std::string& web_dir);
  // After parsing: fills web and viewer from the options; the problem with them, if any.
  std::optional<std::string> finish();

 private:
  std::string web_dir_;
  int port_ = 8080;
  bool no_sim_ = false;
};

}  // namespace fieldline::viewer
