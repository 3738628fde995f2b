// fieldline-fusion: the localization process. Fuses ODOMETRY (layer 1), the line matcher's
// correction of every VISION_LINES frame (layer 2) and FIELD_FEATURES hypotheses (layer 3), each
// at the time it was observed, into ROBOT_STATE on every odometry message, and tracks the ball
// from VISION_BALL into BALL_STATE (fusion_app.hpp).
#include "common/bus/cli.hpp"
#include "common/cli/cli.hpp"
#include "services/fusion/fusion_app.hpp"

namespace cli = fieldline::cli;
namespace bus = fieldline::bus;

int main(int argc, char** argv) {
  cli::App app{
      "Fusion: delay-aware pose estimation from ODOMETRY, VISION_LINES and FIELD_FEATURES "
      "(ROBOT_STATE on every odometry message) and ball tracking from VISION_BALL "
      "(BALL_STATE)."};
  bus::CommonOptions common;
  common.addTo(app);
  fieldline::fusion::FusionAppOptions options;
  options.addTo(app);
  FIELDLINE_PARSE(app, argc, argv);
  return bus::runMain("fusion", [&] {
    common.resolve("fusion");
    return fieldline::fusion::runFusion(options, common);
  });
}
