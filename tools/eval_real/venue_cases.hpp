// Rendered "venue" cases (issue 30, item 8): what a team meets in a new hall, drawn by the
// simulated camera with known truth so that the calibration tools, the tracker and the ball
// detector can be scored on frames they were not tuned on. A case is a YAML manifest
// (tests/data/venue_cases/*.yaml): the field, a camera whose mirror is not the shipped one
// (another distance law, a moved centre, an axis offset, a tilt), the carpet's and lines'
// colours, the realism knobs (grey carpet, colour cast, uneven light, noise), clutter (robots,
// people with shirts in the hall, the ball) and the spots the robot stands on, turning on each.
//
// The frames are what a team has at a venue; the truth (the true mirror, every frame's pose, the
// ball) is only for scoring. Rendering is deterministic: the same manifest, the same bytes.
// Plain library: no bus, no clock.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/camera/frame.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/config/config.hpp"
#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "services/camera/realism.hpp"
#include "services/camera/sim_renderer.hpp"

namespace fieldline::venue {

using camera::Vec2;

// The camera's true mirror. law "preset": the base camera's distance function; "tan": the floor
// distance D(r, b) = scale * tan(rate * r + tilt * cos(b - tilt_bearing)), an equiangular-like
// law quite unlike the shipped linear-exponential one, with the camera tilted by `tilt` toward
// axis bearing `tilt_bearing` (far distances grow on that side, shrink on the other).
struct VenueMirror {
  std::string law = "preset";
  double scale = 1.37;   // m
  double rate = 0.0098;  // rad per px (at the base camera's image size)
  // Mirror centre moved from the base camera's, px; axis offset from the robot's centre, m.
  Vec2 centre_shift = Vec2::Zero();
  Vec2 axis_offset = Vec2::Zero();
  double tilt_deg = 0.0;
  double tilt_bearing_deg = 0.0;
};

// The robot stands at `position` (field frame, m) and turns on the spot: one frame per heading.
struct VenueSpot {
  Vec2 position = Vec2::Zero();
  std::vector<double> headings_deg;
};

struct VenueCase {
  std::string name;
  std::string description;
  std::string file;  // the manifest it was read from
  std::string field = "msl";
  std::string camera = "omni_sim";  // image size, the renderer's scene settings
  VenueMirror mirror;
  camera::RenderParams render;  // the camera's, with the case's colours and realism
  std::vector<VenueSpot> spots;
  std::optional<Vec2> ball;  // on the floor, field frame
  std::vector<Vec2> robots;  // other robots, field frame
  int people = 0;            // people standing in the hall beyond the lines
  std::uint32_t seed = 1;
  // What fieldline-eval-real requires of the case's figures (`expect:` in the manifest): names
  // as eval_real.hpp lists them, each a bound.
  std::map<std::string, double> expect;
};

// Reads a manifest; throws config::Error naming file:line for anything wrong. Field and camera
// are presets or paths (paths relative to the manifest).
VenueCase loadVenueCase(const std::string& path);
// The same from a parsed node (`file` for messages and relative paths).
VenueCase loadVenueCase(const config::Node& root);

// The case's true mirror model (the base camera's image size and radii).
camera::MirrorModel venueMirror(const VenueCase& c);

struct VenueFrame {
  std::vector<std::uint8_t> yuyv;
  geometry::Pose2 pose;  // the robot's centre, field frame
  int spot = 0;
  // Where the ball's centre is imaged, when it lies in the mirror's useful zone.
  std::optional<Vec2> ball_pixel;
};

struct RenderedVenue {
  VenueCase spec;
  camera::MirrorModel mirror;
  field::FieldModel field;
  std::vector<camera::SimBox> clutter;  // the people, as drawn
  std::vector<VenueFrame> frames;

  camera::FrameView view(std::size_t frame) const;
};

// Renders every spot's headings in order.
RenderedVenue renderVenue(const VenueCase& c);

// Writes the frames as PNG (frame_00.png, ...) and the truth (truth.yaml: poses, spots, ball,
// the true mirror's parameters) into `folder` (created). Returns the frame paths.
std::vector<std::string> writeVenue(const RenderedVenue& venue, const std::string& folder);

}  // namespace fieldline::venue
