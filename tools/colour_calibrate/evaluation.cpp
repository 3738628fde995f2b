#include "tools/colour_calibrate/evaluation.hpp"

#include <algorithm>
#include <optional>
#include <stdexcept>

namespace fieldline::calibration {

void ScoreSum::add(const LineScore& s) {
  ++frames;
  points += s.points;
  precise += s.precise;
  visible += s.visible_length;
  covered += s.covered_length;
  // A frame without points has no precision (its recall is 0 if lines were visible).
  if (s.points > 0) min_precision = std::min(min_precision, s.precision);
  min_recall = std::min(min_recall, s.recall);
  frames_meeting += s.precision >= 0.9 && s.recall >= 0.85 ? 1 : 0;
}

std::vector<RealismSetting> realismSettings() {
  std::vector<RealismSetting> out;
  auto add = [&out](const std::string& name, auto&& change) {
    RealismSetting s{name, {}};
    change(s.realism);
    out.push_back(s);
  };
  add("clean", [](camera::RealismParams&) {});
  add("noise", [](camera::RealismParams& p) { p.shot_noise = 14.0; });
  add("washed", [](camera::RealismParams& p) { p.saturation = 0.45; });
  add("cast", [](camera::RealismParams& p) {
    p.saturation = 0.8;
    p.chroma_shift = {8.0, 10.0};
  });
  add("blur", [](camera::RealismParams& p) { p.blur_sigma = 1.2; });
  add("vignetting", [](camera::RealismParams& p) { p.vignetting = 0.5; });
  add("uneven", [](camera::RealismParams& p) {
    p.light_gradient = 0.4;
    p.light_gradient_angle = 1.0;
  });
  add("dim", [](camera::RealismParams& p) { p.light_factor = 0.55; });
  add("bright", [](camera::RealismParams& p) { p.light_factor = 1.35; });
  add("all", [](camera::RealismParams& p) {
    p.light_factor = 0.85;
    p.light_gradient = 0.25;
    p.light_gradient_angle = 2.0;
    p.vignetting = 0.3;
    p.saturation = 0.6;
    p.chroma_shift = {4.0, 6.0};
    p.blur_sigma = 0.8;
    p.shot_noise = 8.0;
  });
  return out;
}

RealismSetting realismSetting(const std::string& name) {
  std::string names;
  for (const RealismSetting& s : realismSettings()) {
    if (s.name == name) return s;
    names += (names.empty() ? "" : ", ") + s.name;
  }
  throw std::invalid_argument("unknown realism setting '" + name + "' (expected one of " + names +
                              ")");
}

SettingResult evaluateSetting(region_tracking::SimCamera& sim, const RealismSetting& setting,
                              const geometry::Pose2& pose, int frames, const FitParams& params,
                              bool shipped) {
  SettingResult result;
  result.setting = setting.name;
  result.pose = pose;
  sim.renderer->realism().setParams(setting.realism);
  camera::SimScene scene;
  scene.robot = pose;
  scene.frame_number = 0;
  const camera::FrameView first = sim.render(scene);
  const std::vector<std::uint8_t> calibrationFrame = sim.frame;
  const camera::FrameView calibrationView{calibrationFrame.data(), first.width, first.height,
                                          first.stride, first.format};
  const std::vector<PosedFrame> posed{{calibrationView, pose}};
  if (shipped) {
    result.calibration.boxes = sim.table.boxes();
  } else {
    result.calibration = calibrate(sim.mirror, sim.field, posed, {}, sim.table.boxes(), params);
  }
  const camera::ColourTable table(result.calibration.boxes);
  result.coverage = measureCoverage(sim.mirror, sim.field, posed, table, params.masks);

  region_tracking::FrameProcessor processor(sim.mirror, table,
                                            region_tracking::defaultVisionParams());
  region_tracking::VisionResult vision;
  for (int i = 0; i < frames; ++i) {
    scene.frame_number = static_cast<std::uint64_t>(i);
    const camera::FrameView view = sim.render(scene);
    processor.process(view, true, vision);
    if (i >= 2) result.score.add(scoreLinePoints(sim.mirror, sim.field, pose, vision.lines, {}));
  }
  sim.renderer->realism().setParams({});
  return result;
}

DriveResult evaluateDrive(region_tracking::SimCamera& sim, const RealismSetting& setting,
                          const camera::ColourTable& calibrated, int frames, double light_from,
                          double light_to,
                          const region_tracking::ColourAdaptationParams& adaptation,
                          const region_tracking::VisionParams& vision) {
  DriveResult result;
  camera::ColourTable table = calibrated;
  std::optional<region_tracking::ColourAdaptation> adapter;
  if (adaptation.enabled) adapter.emplace(calibrated, adaptation);
  result.light_from = light_from;
  result.light_to = light_to;
  const std::vector<geometry::Pose2> poses = region_tracking::motionPoses(
      sim.field, region_tracking::Motion{.speed = 1.5, .omega = 0.5}, frames);
  region_tracking::FrameProcessor processor(sim.mirror, table, vision);
  region_tracking::VisionResult tracked;
  camera::RealismParams realism = setting.realism;
  for (int i = 0; i < frames; ++i) {
    const double t = frames > 1 ? static_cast<double>(i) / (frames - 1) : 0.0;
    realism.light_factor =
        setting.realism.light_factor * (light_from + t * (light_to - light_from));
    sim.renderer->realism().setParams(realism);
    camera::SimScene scene;
    scene.robot = poses[static_cast<std::size_t>(i)];
    scene.frame_number = static_cast<std::uint64_t>(i);
    const camera::FrameView view = sim.render(scene);
    const bool lines = i % 3 == 0;
    processor.process(view, lines, tracked);
    if (adapter) {
      adapter->observe(view, processor.tracker(), table);
      result.min_gain = std::min(result.min_gain, adapter->appliedGain());
      result.max_gain = std::max(result.max_gain, adapter->appliedGain());
    }
    if (lines && i >= 3) {
      result.score.add(scoreLinePoints(sim.mirror, sim.field, scene.robot, tracked.lines, {}));
    }
  }
  if (adapter) {
    result.final_gain = adapter->appliedGain();
    result.rebuilds = adapter->rebuilds();
  }
  sim.renderer->realism().setParams({});
  return result;
}

}  // namespace fieldline::calibration
