#include "services/camera/camera_node.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include <spdlog/spdlog.h>

#include "common/field/field_model.hpp"
#include "common/msg/image.hpp"
#include "common/time/offset_clock.hpp"

namespace fieldline::camera {

namespace {
// Footprint of a teammate when SIM_WORLD does not say (older logs), metres.
constexpr double kDefaultRobotRadius = 0.25;
}  // namespace
namespace {

constexpr std::size_t kPendingSlots = 16;
// SIM_WORLD older than this is not rendered from: the simulator stalled or its clock differs.
constexpr double kMaxWorldAge = 0.5;
// A frame is exposed this long before its render tick (at most the pipeline latency): SIM_WORLD
// comes every 10 ms (in a loaded match received 1.5 ms after its time, p99 9 ms; 1 % of the
// intervals 20 ms), so by then the state at or after the exposure is in and the frame is
// rendered between the two around it instead of carrying the newest up to 10 ms on (issue 34).
constexpr Utime kRenderDelay = 25 * kMicrosPerMilli;
// States further apart than this are not interpolated between (the simulator stalled).
constexpr Utime kMaxInterpolationSpan = 50 * kMicrosPerMilli;
// No body moves this far (m) or turns this much (rad) between two states: a teleport.
constexpr double kJumpDistance = 1.0;
constexpr double kJumpAngle = 1.0;

double millisSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace

std::int8_t imageSourceCode(SourceKind kind) {
  switch (kind) {
    case SourceKind::kSim:
      return image_t::SOURCE_SIM;
    case SourceKind::kV4l2:
      return image_t::SOURCE_V4L2;
    case SourceKind::kVideo:
    case SourceKind::kGstreamer:
      return image_t::SOURCE_VIDEO;
    case SourceKind::kFolder:
      return image_t::SOURCE_FOLDER;
    case SourceKind::kLog:
      return image_t::SOURCE_LOG;
  }
  return image_t::SOURCE_VIDEO;
}

bool sceneFromWorld(const world_state_t& world, int robot_id, Utime when, double exposure,
                    SimScene& scene) {
  const double dt = static_cast<double>(when - world.header.utime) * 1e-6;
  bool found = false;
  for (int k = 0; k < world.num_robots; ++k) {
    if (world.robot_id[k] != robot_id) continue;
    scene.robot = {world.robot_x[k] + world.robot_vx[k] * dt,
                   world.robot_y[k] + world.robot_vy[k] * dt,
                   geometry::normalizeAngle(world.robot_phi[k] + world.robot_omega[k] * dt)};
    scene.velocity = {world.robot_vx[k], world.robot_vy[k]};
    scene.omega = world.robot_omega[k];
    found = true;
  }
  if (!found) return false;
  scene.exposure = exposure;
  scene.robots.clear();
  for (int k = 0; k < world.num_robots; ++k) {
    if (world.robot_id[k] == robot_id) continue;
    scene.robots.push_back(
        {{world.robot_x[k] + world.robot_vx[k] * dt, world.robot_y[k] + world.robot_vy[k] * dt},
         world.robot_radius > 0.0f ? static_cast<double>(world.robot_radius) : kDefaultRobotRadius,
         true});
  }
  for (int k = 0; k < world.num_opponents; ++k) {
    scene.robots.push_back({{world.opponent_x[k], world.opponent_y[k]},
                            std::clamp(static_cast<double>(world.opponent_radius[k]), 0.05, 1.0),
                            false});
  }
  scene.ball.reset();
  if (world.ball_radius > 0.0f) {
    scene.ball = SimBall{{world.ball_x + world.ball_vx * dt, world.ball_y + world.ball_vy * dt},
                         static_cast<double>(world.ball_radius)};
  }
  return true;
}

namespace {

int indexOfRobot(const world_state_t& world, int robot_id) {
  for (int k = 0; k < world.num_robots; ++k) {
    if (world.robot_id[k] == robot_id) return k;
  }
  return -1;
}

// `a` + f (`b` - `a`) into `out` unless `a` and `b` are a jump apart.
bool between(Vec2 a, Vec2 b, double f, Vec2& out) {
  if ((b - a).norm() > kJumpDistance) return false;
  out = a + f * (b - a);
  return true;
}

}  // namespace

ScenePose sceneBetweenWorlds(const world_state_t& before, const world_state_t& after, int robot_id,
                             Utime when, double exposure, SimScene& scene) {
  if (!sceneFromWorld(before, robot_id, when, exposure, scene)) return ScenePose::kMissing;
  const Utime t0 = before.header.utime;
  const Utime span = after.header.utime - t0;
  if (when < t0 || when > after.header.utime || span > kMaxInterpolationSpan) {
    return ScenePose::kExtrapolated;
  }
  const double f = span > 0 ? static_cast<double>(when - t0) / static_cast<double>(span) : 0.0;
  const int i0 = indexOfRobot(before, robot_id);
  const int i1 = indexOfRobot(after, robot_id);
  if (i1 < 0 || after.robot_kidnaps[i1] != before.robot_kidnaps[i0]) {
    return ScenePose::kExtrapolated;
  }
  const double turn = geometry::angleDiff(after.robot_phi[i1], before.robot_phi[i0]);
  Vec2 position;
  if (std::abs(turn) > kJumpAngle ||
      !between({before.robot_x[i0], before.robot_y[i0]}, {after.robot_x[i1], after.robot_y[i1]}, f,
               position)) {
    return ScenePose::kExtrapolated;
  }
  scene.robot = {position.x(), position.y(),
                 geometry::normalizeAngle(before.robot_phi[i0] + f * turn)};
  scene.velocity = {after.robot_vx[i1], after.robot_vy[i1]};
  scene.omega = after.robot_omega[i1];
  // The other bodies in sceneFromWorld's order: teammates, then opponents.
  std::size_t j = 0;
  for (int k = 0; k < before.num_robots; ++k) {
    if (before.robot_id[k] == robot_id) continue;
    const int m = indexOfRobot(after, before.robot_id[k]);
    if (m >= 0 && after.robot_kidnaps[m] == before.robot_kidnaps[k]) {
      between({before.robot_x[k], before.robot_y[k]}, {after.robot_x[m], after.robot_y[m]}, f,
              scene.robots[j].position);
    }
    ++j;
  }
  if (after.num_opponents == before.num_opponents) {
    for (int k = 0; k < before.num_opponents; ++k, ++j) {
      between({before.opponent_x[k], before.opponent_y[k]},
              {after.opponent_x[k], after.opponent_y[k]}, f, scene.robots[j].position);
    }
  }
  if (scene.ball && after.ball_radius > 0.0f) {
    between({before.ball_x, before.ball_y}, {after.ball_x, after.ball_y}, f, scene.ball->position);
  }
  return ScenePose::kInterpolated;
}

// --- SimCameraNode ---

SimCameraNode::SimCameraNode(bus::Node& node, bus::BusId sim_bus, CameraConfig config,
                             std::string field_preset, std::string raster_cache_dir)
    : node_(node),
      config_(std::move(config)),
      field_preset_(std::move(field_preset)),
      raster_cache_dir_(std::move(raster_cache_dir)),
      pending_(kPendingSlots) {
  render_delay_ =
      std::min(kRenderDelay, static_cast<Utime>(std::llround(config_.pipeline.latency * 1e6)));
  if (!field_preset_.empty()) {
    field_name_ = field_preset_;
    makeRenderer(field_preset_);
  }
  // SIM_WORLD (100 Hz) does not wake the camera: its messages are handled just before the frame
  // timer (issue 32: 100 wake-ups a second fewer per camera), which renders the frame exposed
  // render_delay_ earlier between the states around it.
  node_.subscribeDeferred(
      bus::channels::kSimWorld, [this](const world_state_t& w) { onWorld(w); }, sim_bus);
  const auto period =
      static_cast<Utime>(std::llround(kMicrosPerSecond / config_.pipeline.frame_rate));
  node_.every(period, [this] { onFrameTick(); });
  // Frames come only while the simulator's world does: without it the camera says so (WARN
  // "CAMERA_IMAGE silent") instead of ok at 0 Hz (issue 34, red-team finding 5).
  node_.requireOutput(bus::channels::kCameraImage,
                      bus::kRequiredRateFraction * config_.pipeline.frame_rate);
  period_start_ = node_.now();
  node_.every(kMicrosPerSecond, [this] { reportRates(); });
}

void SimCameraNode::makeRenderer(const std::string& field_name) {
  renderer_ = std::make_unique<SimRenderer>(
      config_.model.mirror, field::loadFieldPreset(field_name),
      renderParamsOf(config_, "the simulated camera (--source sim)"), raster_cache_dir_);
  // Where the floor pass's raster lives: one mapped copy for every camera on the machine, or this
  // process's own.
  const std::string where =
      renderer_->rasterMapped()
          ? "mapped read-only from " + renderer_->rasterPath() + " (shared by the cameras)"
          : std::string("in this process's memory");
  switch (renderer_->rasterSource()) {
    case RasterSource::kLoadedFromCache:
      spdlog::info("floor raster of '{}' from the cache: {}", field_name, where);
      break;
    case RasterSource::kRebuiltBadCache:
      spdlog::warn("floor raster of '{}' rebuilt, {}: the cache file was not usable ({})",
                   field_name, where, renderer_->rasterProblem());
      break;
    case RasterSource::kBuilt:
      if (!renderer_->rasterProblem().empty()) {
        spdlog::warn("floor raster of '{}' built, {}: {}", field_name, where,
                     renderer_->rasterProblem());
      } else {
        spdlog::info("floor raster of '{}' built, {}", field_name, where);
      }
      break;
  }
}

void SimCameraNode::onWorld(const world_state_t& world) {
  if (!field_preset_.empty() && world.field != field_preset_) {
    // Rendering another field than the simulator's would feed the robot wrong lines.
    node_.reportError("field_mismatch", "SIM_WORLD is on field '" + world.field +
                                            "' but this camera renders '" + field_preset_ + "'");
    worlds_.clear();
    return;
  }
  if (field_preset_.empty() && world.field != field_name_) {
    // First message, or the simulator switched fields: build the floor raster for it.
    try {
      makeRenderer(world.field);
      field_name_ = world.field;
      spdlog::info("rendering the '{}' field", field_name_);
      // Building took a while: this state is old now, wait for the next one (and never render
      // the old field's world with the new field's renderer).
      worlds_.clear();
      return;
    } catch (const std::exception& e) {
      node_.reportError("field", "cannot load field '" + world.field + "': " + e.what());
      return;
    }
  }
  if (!worlds_.empty()) {
    // The same state again (a duplicate datagram) adds nothing; an older one means the simulator
    // restarted, and the states before are another world.
    if (world.header.utime == worlds_.newest().header.utime) return;
    if (world.header.utime < worlds_.newest().header.utime) worlds_.clear();
  }
  worlds_.push(world);
}

void SimCameraNode::onFrameTick() {
  if (!renderer_ || worlds_.empty()) return;  // waiting for the simulator
  // The frame is stamped on the robot's clock; the simulator's world is on the true time.
  const Utime exposure_time = node_.now() - render_delay_;
  const Utime exposure_truth = toTruth(node_.clock(), exposure_time);
  const Utime newest = worlds_.newest().header.utime;
  if (std::abs(static_cast<double>(exposure_truth - newest)) * 1e-6 > kMaxWorldAge) {
    node_.reportError("stale_world",
                      "SIM_WORLD is " +
                          std::to_string((exposure_truth - newest) / kMicrosPerMilli) +
                          " ms away from the exposure time");
    return;
  }
  // The newest state at or before the exposure and the first at or after it.
  const world_state_t* before = nullptr;
  const world_state_t* after = nullptr;
  for (std::size_t i = 0; i < worlds_.size(); ++i) {
    const world_state_t& w = worlds_[i];
    if (w.header.utime <= exposure_truth) before = &w;
    if (w.header.utime >= exposure_truth && after == nullptr) after = &w;
  }
  ScenePose pose = ScenePose::kMissing;
  if (before != nullptr && after != nullptr) {
    pose = sceneBetweenWorlds(*before, *after, node_.robotId(), exposure_truth,
                              config_.pipeline.exposure, scene_);
  } else if (sceneFromWorld(before != nullptr ? *before : worlds_[0], node_.robotId(),
                            exposure_truth, config_.pipeline.exposure, scene_)) {
    pose = ScenePose::kExtrapolated;  // none after the exposure yet, or none before it
  }
  if (pose == ScenePose::kMissing) {
    node_.reportError("no_pose",
                      "robot " + std::to_string(node_.robotId()) + " is not in SIM_WORLD");
    return;
  }
  const auto slot_it =
      std::find_if(pending_.begin(), pending_.end(), [](const Pending& p) { return !p.in_flight; });
  if (slot_it == pending_.end()) {
    node_.reportError("pipeline_full", "more frames in flight than slots; frame dropped");
    return;
  }
  if (pose == ScenePose::kExtrapolated) {
    ++frames_extrapolated_;
    ++extrapolated_in_period_;
  }
  scene_.frame_number = static_cast<std::uint64_t>(frames_rendered_);
  const auto start = std::chrono::steady_clock::now();
  renderer_->render(scene_, frame_buffer_);
  const double render_ms = millisSince(start);
  node_.status().onProcessing(render_ms);
  render_ms_in_period_ += render_ms;

  image_t& img = slot_it->image;
  img.header.utime = exposure_time;
  img.source = image_t::SOURCE_SIM;
  img.frame_number = frames_rendered_++;
  img.exposure_us = static_cast<std::int32_t>(std::lround(config_.pipeline.exposure * 1e6));
  img.data.swap(frame_buffer_);  // the slot's old buffer becomes the next render target
  msg::toMessage(FrameView{img.data.data(), renderer_->width(), renderer_->height(),
                           renderer_->stride(), PixelFormat::kYuyv},
                 img);
  frame_buffer_.resize(img.data.size());
  slot_it->in_flight = true;
  const std::size_t slot = static_cast<std::size_t>(slot_it - pending_.begin());
  const auto latency = static_cast<Utime>(std::llround(config_.pipeline.latency * 1e6));
  node_.at(exposure_time + latency, [this, slot] { publishPending(slot); });
}

void SimCameraNode::publishPending(std::size_t slot) {
  Pending& p = pending_[slot];
  if (deliver_) {
    deliver_(p.image);
    ++frames_published_;
    ++frames_in_period_;
  } else if (node_.publish(bus::channels::kCameraImage, p.image, frames_bus_)) {
    ++frames_published_;
    ++frames_in_period_;
    if (preview_ != nullptr) preview_->onFrame(p.image);
  }
  p.in_flight = false;
}

void SimCameraNode::reportRates() {
  const Utime now = node_.now();
  const double seconds = std::max(1e-3, static_cast<double>(now - period_start_) * 1e-6);
  node_.setMetric("frame_rate_hz", static_cast<double>(frames_in_period_) / seconds);
  node_.setMetric("render_ms",
                  frames_in_period_ > 0 ? render_ms_in_period_ / frames_in_period_ : 0.0);
  // Frames of the last period rendered at a pose carried from the newest state (no later one
  // in time, or across a jump): 0 while the simulator keeps up.
  node_.setMetric("frames_extrapolated", static_cast<double>(extrapolated_in_period_));
  frames_in_period_ = 0;
  extrapolated_in_period_ = 0;
  render_ms_in_period_ = 0.0;
  period_start_ = now;
}

// --- real sources ---

std::int64_t runFrameSource(bus::Node& node, FrameSource& source, const PipelineParams& pipeline,
                            const FrameSourceOptions& options) {
  SourceFrame frame;
  image_t img;
  std::int64_t published = 0;
  std::int64_t in_period = 0;
  double capture_ms_in_period = 0.0;
  Utime period_start = node.now();
  std::int64_t reported_errors = 0;
  const auto latency = static_cast<Utime>(std::llround(pipeline.latency * 1e6));
  const Utime pace_period =
      options.pace_fps > 0.0 ? static_cast<Utime>(std::llround(1e6 / options.pace_fps)) : 0;
  Utime next_due = node.now();
  while (!node.stopRequested() && (options.max_frames == 0 || published < options.max_frames)) {
    if (pace_period > 0) {
      // Handle traffic and timers while waiting for the next frame's turn.
      for (Utime now = node.now(); now < next_due && !node.stopRequested(); now = node.now()) {
        node.spinOnce(static_cast<int>(std::max<Utime>(1, (next_due - now) / kMicrosPerMilli)));
      }
      next_due = std::max(next_due + pace_period, node.now());
    } else {
      node.spinOnce(0);
    }
    const auto start = std::chrono::steady_clock::now();
    const bool got = source.next(frame);
    if (got && options.keep_stamps && frame.recorded_utime) {
      // A recorded frame goes out when its time comes on the node's clock (the log's time).
      const Utime due = *frame.recorded_utime + latency;
      for (Utime now = node.now(); now < due && !node.stopRequested(); now = node.now()) {
        node.spinOnce(static_cast<int>(std::clamp<Utime>((due - now) / kMicrosPerMilli, 1, 100)));
      }
      if (node.stopRequested()) break;
    }
    const Utime received = node.now();
    for (; reported_errors < source.errors(); ++reported_errors) {
      node.reportError("bad_frame", source.lastError());
    }
    if (!got) break;
    const double capture_ms = millisSince(start);
    node.status().onProcessing(capture_ms);
    capture_ms_in_period += capture_ms;

    img.header.utime =
        options.keep_stamps && frame.recorded_utime ? *frame.recorded_utime : received - latency;
    img.source = imageSourceCode(source.kind());
    img.frame_number = frame.frame_number;
    img.exposure_us = static_cast<std::int32_t>(std::lround(pipeline.exposure * 1e6));
    img.data.swap(frame.bytes);
    const FrameView view{img.data.data(), frame.width, frame.height, frame.stride, frame.format};
    if (!view.valid() || img.data.size() < static_cast<std::size_t>(frame.stride) * frame.height) {
      node.reportError("bad_frame", "a source delivered a frame with an unusable layout");
    } else {
      msg::toMessage(view, img);
      if (node.publish(bus::channels::kCameraImage, img, options.frames_bus)) {
        ++published;
        ++in_period;
        if (options.preview != nullptr) options.preview->onFrame(img);
      }
    }
    frame.bytes.swap(img.data);

    if (received - period_start >= kMicrosPerSecond) {
      const double seconds = static_cast<double>(received - period_start) * 1e-6;
      node.setMetric("frame_rate_hz", static_cast<double>(in_period) / seconds);
      node.setMetric("capture_ms", in_period > 0 ? capture_ms_in_period / in_period : 0.0);
      in_period = 0;
      capture_ms_in_period = 0.0;
      period_start = received;
    }
  }
  node.spinOnce(0);
  return published;
}

}  // namespace fieldline::camera
