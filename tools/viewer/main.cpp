// fieldline-viewer: the live field view in the browser (docs/viewer.md). Listens to every robot's
// bus and the simulator's and serves the page, GET /state.json, GET /camera.json?robot=N and the
// WebSocket /ws. Read-only: anything but GET gets 405.
#include <iostream>
#include <limits>

#include <spdlog/spdlog.h>

#include "common/cli/cli.hpp"
#include "common/config/paths.hpp"
#include "common/field/field_model.hpp"
#include "tools/viewer/playback.hpp"
#include "tools/viewer/viewer_cli.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  cli::App app{"Live field view in the browser: the robots' and the simulator's buses as a page"};
  // The page ships with the binary: <prefix>/share/fieldline/web (build/share/fieldline/web in a
  // build tree, a symlink to tools/viewer/web).
  viewer::ViewerCommandLine cli(app, config::dataDirectory() + "/web");
  FIELDLINE_PARSE(app, argc, argv);
  if (const auto problem = cli.finish()) {
    std::cerr << *problem << "\n";
    return 2;
  }
  spdlog::set_level(spdlog::level::from_str(cli.common.log_level));
  spdlog::set_pattern("%H:%M:%S.%e %^%l%$ viewer %v");

  return bus::runMain("viewer", [&] {
    const field::FieldModel field = field::loadFieldPreset(cli.field);
    if (cli.common.print_io) {
      return bus::printIo(viewer::viewerIo(cli.viewer)
                              .link("http", cli.web.address + ":" + std::to_string(cli.web.port),
                                    bus::Link::Direction::kOut));
    }
    if (cli.common.check_args) return 0;
    SystemClock clock;
    bus::installStopSignals();
    if (!cli.log.empty()) {
      // A recording instead of the buses (docs/viewer.md, "Watching a recording").
      return viewer::runPlayback(cli.log, cli.web, viewer::fieldJson(field),
                                 {.play = cli.play, .speed = cli.speed});
    }
    const std::string primary = viewer::viewerPrimaryUrl(cli.viewer);
    bus::NodeOptions node_options{.process = "viewer", .robot_id = 0, .url = primary};
    if (cli.replay_bus) {
      // A replay's messages carry the stamps of the recording: neither old nor new is refused.
      node_options.max_age_us = node_options.future_tolerance_us =
          std::numeric_limits<Utime>::max() / 4;
    }
    bus::Node node(node_options, clock);
    viewer::WebServer server(cli.web, viewer::fieldJson(field));
    server.setRoute(viewer::pageRoute(cli.web.web_dir));
    viewer::ViewerNode viewer(node, cli.viewer, server);
    // Scripts (scripts/demo, the tests) read the address from this line.
    spdlog::info("serving http://{}:{}/ ({} robots{}, field {})", cli.web.address, server.port(),
                 cli.viewer.robots.size(), cli.viewer.sim ? " and the simulator" : "",
                 field.name());
    return node.run();
  });
}
