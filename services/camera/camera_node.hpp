// The camera process's bus side: turns sources into CAMERA_IMAGE messages.
//
//   sim:   SimCameraNode subscribes SIM_WORLD on the simulator's bus, renders its robot's view
//          at the configured frame rate, stamps utime with the exposure time (a render delay
//          before the tick, so the SIM_WORLD after it has come) and publishes each frame
//          `latency` after the exposure, as a real camera delivers it.
//   real:  runFrameSource() reads a FrameSource (camera, video, GStreamer, folder, log) and
//          publishes every frame at once with utime = receive time - latency.
// Both publish frames in the layout they have (YUYV from the renderer, BGR or YUYV from real
// sources) and report frame_rate_hz and render_ms / capture_ms in SERVICE_STATUS.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fieldline/image_t.hpp>
#include <fieldline/world_state_t.hpp>

#include "common/bus/node.hpp"
#include "services/camera/camera_config.hpp"
#include "services/camera/camera_preview_node.hpp"
#include "services/camera/sim_renderer.hpp"
#include "services/camera/sources.hpp"

namespace fieldline::camera {

// Fills `scene` with what robot `robot_id` sees in `world` at time `when` (µs): poses
// extrapolated with the velocities from the state's utime, other own robots as teammates,
// opponents with their radius, the ball. `scene` keeps its vectors' capacity from frame to frame.
// Returns false (scene unspecified) if the robot is not in the message.
bool sceneFromWorld(const world_state_t& world, int robot_id, Utime when, double exposure,
                    SimScene& scene);

enum class ScenePose {
  kMissing,       // the robot is not in the state
  kInterpolated,  // its pose interpolated between two states around `when`
  kExtrapolated,  // carried from `before` with its velocities (sceneFromWorld)
};

// Fills `scene` at `when` from the two states around it (before.utime <= when <= after.utime,
// at most 50 ms apart): every pose interpolated between them, positions linearly and the own
// robot's heading along the shorter arc, velocities `after`'s (SIM_WORLD's are the mean since
// the previous state). Not across a jump: a body kidnapped in between (robot_kidnaps) or moved
// by more than no body moves in that time (1 m or 1 rad) is carried from `before` as
// sceneFromWorld does, and so is everything when the states do not bracket `when`.
// Returns kInterpolated when the own robot's pose was interpolated.
ScenePose sceneBetweenWorlds(const world_state_t& before, const world_state_t& after, int robot_id,
                             Utime when, double exposure, SimScene& scene);

class SimCameraNode {
 public:
  // `field_preset` empty: build the renderer for the field SIM_WORLD names (on its first
  // message). Subscribes SIM_WORLD on `sim_bus` and starts the frame timer on `node`.
  // `raster_cache_dir`: where the floor raster is cached (empty: built every time).
  SimCameraNode(bus::Node& node, bus::BusId sim_bus, CameraConfig config,
                std::string field_preset = {}, std::string raster_cache_dir = {});

  std::int64_t framesRendered() const { return frames_rendered_; }
  std::int64_t framesPublished() const { return frames_published_; }
  // Frames rendered at a pose carried from the newest SIM_WORLD because none at or after the
  // exposure had come by the render (the simulator stalled or late) or it was across a jump.
  std::int64_t framesExtrapolated() const { return frames_extrapolated_; }
  // What the newest frame was rendered from (its robot's pose, the other bodies).
  const SimScene& lastScene() const { return scene_; }

  // Hands each frame, when it is due (exposure + latency), to `deliver` instead of publishing
  // it as CAMERA_IMAGE: a stand-in camera device (--to-pipe).
  using Delivery = std::function<void(const image_t& frame)>;
  void deliverTo(Delivery deliver) { deliver_ = std::move(deliver); }

  // Publishes CAMERA_IMAGE on `frames_bus` (default: the node's primary bus) and hands each
  // published frame to `preview` (may be null; must outlive this node).
  void publishOn(bus::BusId frames_bus, PreviewPublisher* preview) {
    frames_bus_ = frames_bus;
    preview_ = preview;
  }

 private:
  struct Pending {
    image_t image;
    bool in_flight = false;
  };

  void onWorld(const world_state_t& world);
  void onFrameTick();
  void publishPending(std::size_t slot);
  // Builds renderer_ for the field (floor raster from the cache when there is a valid one).
  void makeRenderer(const std::string& field_name);
  void reportRates();

  bus::Node& node_;
  CameraConfig config_;
  std::string field_preset_;
  std::string field_name_;
  std::string raster_cache_dir_;
  std::unique_ptr<SimRenderer> renderer_;
  Delivery deliver_;
  bus::BusId frames_bus_ = bus::kPrimaryBus;
  PreviewPublisher* preview_ = nullptr;
  // The newest SIM_WORLDs, oldest first, in slots written over in place (SIM_WORLD comes 100
  // times a second; copying into a kept slot reuses its vectors).
  class WorldHistory {
   public:
    // 16: the render delay's states at up to 560 SIM_WORLDs a second, and one before.
    static constexpr std::size_t kSlots = 16;
    void clear() { size_ = 0; }
    bool empty() const { return size_ == 0; }
    std::size_t size() const { return size_; }
    // 0 is the oldest.
    const world_state_t& operator[](std::size_t i) const { return slots_[(oldest_ + i) % kSlots]; }
    const world_state_t& newest() const { return (*this)[size_ - 1]; }
    void push(const world_state_t& world) {
      if (size_ < kSlots) {
        slots_[(oldest_ + size_++) % kSlots] = world;
      } else {
        slots_[oldest_] = world;
        oldest_ = (oldest_ + 1) % kSlots;
      }
    }

   private:
    std::array<world_state_t, kSlots> slots_{};
    std::size_t oldest_ = 0;
    std::size_t size_ = 0;
  };
  WorldHistory worlds_;
  // How long before the tick the frame is exposed (µs): so the SIM_WORLD after it is in.
  Utime render_delay_ = 0;
  std::vector<Pending> pending_;
  std::vector<std::uint8_t> frame_buffer_;
  SimScene scene_;
  std::int64_t frames_rendered_ = 0;
  std::int64_t frames_published_ = 0;
  std::int64_t frames_extrapolated_ = 0;
  std::int64_t extrapolated_in_period_ = 0;
  std::int64_t frames_in_period_ = 0;
  double render_ms_in_period_ = 0.0;
  Utime period_start_ = 0;
};

struct FrameSourceOptions {
  // Deliver at most this many frames per second (folders, files, logs); 0 = as fast as the
  // source gives them (cameras pace themselves).
  double pace_fps = 0.0;
  // Stop after this many frames (0 = no limit).
  std::int64_t max_frames = 0;
  // Frames with a recorded exposure time (LCM logs) keep it as header.utime, and each is
  // published when the node's clock reaches that time plus the pipeline latency (run the node
  // on a clock at the log's time: logClock()); pace_fps does not apply to them. False: every
  // frame is stamped receive time - latency, like a camera's.
  bool keep_stamps = false;
  // CAMERA_IMAGE goes to this bus of the node.
  bus::BusId frames_bus = bus::kPrimaryBus;
  // Gets every published frame (CAMERA_PREVIEW); null: none.
  PreviewPublisher* preview = nullptr;
};

// Publishes every frame of `source` as CAMERA_IMAGE until it ends or the node is asked to stop.
// Returns the number of frames published.
std::int64_t runFrameSource(bus::Node& node, FrameSource& source, const PipelineParams& pipeline,
                            const FrameSourceOptions& options);

// The image_t SOURCE_ constant for a source (pixels and layout: common/msg/image.hpp).
std::int8_t imageSourceCode(SourceKind kind);

}  // namespace fieldline::camera
