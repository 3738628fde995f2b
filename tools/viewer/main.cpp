// fieldline-viewer: the live field view in the browser (docs/viewer.md). Listens to every robot's
// bus and the simulator's and serves the page, GET /state.json, GET /camera.json?robot=N and the
// WebSocket /ws. Read-only: anything but GET gets 405.
#include <iostream>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "common/config/paths.hpp"
#include "common/field/field_model.hpp"
#include "tools/viewer/viewer_cli.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  CLI::App app{"Live field view in the browser: the robots' and the simulator's buses as a page"};
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
    if (cli.common.check_args) return 0;
    SystemClock clock;
    bus::installStopSignals();
    const std::string primary = viewer::viewerPrimaryUrl(cli.viewer);
    bus::Node node({.process = "viewer", .robot_id = 0, .url = primary}, clock);
    viewer::WebServer server(cli.web, viewer::fieldJson(field));
    viewer::ViewerNode viewer(node, cli.viewer, server);
    // Scripts (scripts/demo, the tests) read the address from this line.
    spdlog::info("serving http://{}:{}/ ({} robots{}, field {})", cli.web.address, server.port(),
                 cli.viewer.robots.size(), cli.viewer.sim ? " and the simulator" : "",
                 field.name());
    return node.run();
  });
}
