// fieldline-team-png: a picture of one robot's team picture. Listens to robot N's bus (and the
// simulator's, for the truth) until a TEAM_STATE shows at least --min-present robots, then draws
// it on the field: every present robot at its pose with its 2-sigma circle (the robot itself
// outlined in white), each robot's own ball (small, in its colour), the fused team ball (orange,
// with its 2-sigma ellipse) and, when SIM_WORLD is heard, the true robots and ball as grey
// rings. A legend line gives the ages and clock offsets.
//
//   fieldline-team-png --robot 1 --out docs/images/team_picture.png --min-present 6
#include <cstdio>
#include <optional>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/bus/urls.hpp"
#include "common/cli/cli.hpp"
#include "common/msg/team_state.hpp"
#include "common/msg/world_state.hpp"
#include "common/time/clock.hpp"
#include "tools/team_png/team_picture_png.hpp"

using namespace fieldline;

namespace {

struct Options {
  int robot = 1;
  std::string out = "team_picture.png";
  std::string field_name = "msl";
  int min_present = 6;
  double timeout_s = 60.0;
  double px_per_m = 40.0;

  void addTo(cli::App& app) {
    app.add_option("--robot", robot, "Robot whose TEAM_STATE to draw")->check(cli::Range(1, 6));
    app.add_option("--out", out, "PNG to write")->capture_default_str();
    app.add_option("--field", field_name, "Field preset")->capture_default_str();
    app.add_option("--min-present", min_present, "Wait for this many present robots")
        ->check(cli::Range(1, 6))
        ->capture_default_str();
    app.add_option("--timeout", timeout_s, "Give up after this many seconds")
        ->check(cli::Range(1.0, 3600.0))
        ->capture_default_str();
    app.add_option("--px-per-m", px_per_m, "Scale")->check(cli::Range(5.0, 200.0));
  }
};

struct Heard {
  std::optional<perception::TeamState> picture;
  std::optional<perception::WorldTruth> truth;
};

// Listens until a TEAM_STATE with --min-present robots and a team ball arrives (or the timeout).
Heard listen(const Options& o) {
  SystemClock clock;
  bus::Node node({.process = "team_png",
                  .robot_id = 0,
                  .url = bus::robotBusUrl(o.robot),
                  .status_period_us = 0},
                 clock);
  const bus::BusId sim = node.addBus(bus::simBusUrl());
  Heard heard;
  node.subscribe(
      bus::channels::kSimWorld, [&](const world_state_t& w) { heard.truth = msg::fromMessage(w); },
      sim);
  node.subscribe(bus::channels::kTeamState, [&](const team_state_t& m) {
    if (heard.picture) return;
    const perception::TeamState s = msg::fromMessage(m);
    int present = 0;
    for (const auto& r : s.robots)
      present += r.present ? 1 : 0;
    if (present >= o.min_present && s.team_ball_valid) heard.picture = s;
  });
  bus::installStopSignals();
  const Utime start = clock.monotonicNow();
  while (!heard.picture && !bus::stopSignalReceived() &&
         clock.monotonicNow() - start < static_cast<Utime>(o.timeout_s * 1e6)) {
    node.spinOnce(100);
  }
  return heard;
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Draws robot N's TEAM_STATE (its team picture) on the field into a PNG, with the "
      "simulator's truth as grey rings when SIM_WORLD is heard."};
  Options o;
  o.addTo(app);
  FIELDLINE_PARSE(app, argc, argv);

  return bus::runMain("team_png", [&]() -> int {
    const field::FieldModel field = field::loadFieldPreset(o.field_name);
    const Heard heard = listen(o);
    if (!heard.picture) {
      std::fprintf(stderr, "no TEAM_STATE with %d robots present and a team ball on robot %d\n",
                   o.min_present, o.robot);
      return 1;
    }
    const cv::Mat image = team_png::drawTeamPicture(
        field, *heard.picture, o.robot, heard.truth ? &*heard.truth : nullptr, o.px_per_m);
    if (!cv::imwrite(o.out, image)) throw std::runtime_error("cannot write " + o.out);
    std::printf("%s\n", o.out.c_str());
    return 0;
  });
}
