#include "tools/eval_real/venue_cases.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <stdexcept>

#include <fmt/core.h>

#include "common/camera/image_io.hpp"
#include "common/config/paths.hpp"

namespace fieldline::venue {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

camera::Bgr loadBgr(const config::Node& n, const std::string& key) {
  const std::vector<int> c = n.getList<int>(key, 3);
  for (const int x : c) {
    if (x < 0 || x > 255) n.fail(key, "colour components must be in 0..255");
  }
  return {static_cast<std::uint8_t>(c[0]), static_cast<std::uint8_t>(c[1]),
          static_cast<std::uint8_t>(c[2])};
}

Vec2 loadVec2(const config::Node& n, const std::string& key, double limit) {
  const std::vector<double> v = n.getList<double>(key, 2);
  if (!(std::abs(v[0]) <= limit && std::abs(v[1]) <= limit)) {
    n.fail(key, fmt::format("components must be within +-{}", limit));
  }
  return {v[0], v[1]};
}

VenueMirror loadMirror(const config::Node& n) {
  VenueMirror m;
  m.law = n.has("law") ? n.getChoice("law", {"preset", "tan"}) : "preset";
  m.scale = n.getOr<double>("scale", m.scale, 0.05, 20.0);
  m.rate = n.getOr<double>("rate", m.rate, 1e-4, 0.1);
  if (n.has("centre_shift")) m.centre_shift = loadVec2(n, "centre_shift", 100.0);
  if (n.has("axis_offset")) m.axis_offset = loadVec2(n, "axis_offset", 0.5);
  m.tilt_deg = n.getOr<double>("tilt_deg", 0.0, -10.0, 10.0);
  m.tilt_bearing_deg = n.getOr<double>("tilt_bearing_deg", 0.0, -360.0, 360.0);
  n.rejectUnknownKeys();
  return m;
}

// A person in the hall: legs, shirt and head as three boxes.
void addPerson(const Vec2& at, const camera::Bgr& shirt, std::vector<camera::SimBox>& out) {
  const Eigen::Vector3d half(0.22, 0.15, 0.0);
  auto box = [&](double z0, double z1, camera::Bgr colour, double shrink) {
    camera::SimBox b;
    b.lo = Eigen::Vector3d(at.x() - half.x() * shrink, at.y() - half.y() * shrink, z0);
    b.hi = Eigen::Vector3d(at.x() + half.x() * shrink, at.y() + half.y() * shrink, z1);
    b.colour = colour;
    out.push_back(b);
  };
  box(0.0, 0.85, camera::Bgr{60, 45, 40}, 0.8);
  box(0.85, 1.5, shirt, 1.0);
  box(1.5, 1.75, camera::Bgr{120, 150, 200}, 0.5);
}

// Where people stand: 0.6 to 2.5 m beyond a touch line or a goal line.
Vec2 placeInHall(const field::FieldModel& field, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double hx = field.length() / 2;
  const double hy = field.width() / 2;
  const double sign = unit(rng) < 0.5 ? -1.0 : 1.0;
  const double beyond = 0.6 + 1.9 * unit(rng);
  if (unit(rng) < 0.7) return {(2 * unit(rng) - 1) * (hx + 1.0), sign * (hy + beyond)};
  return {sign * (hx + beyond), (2 * unit(rng) - 1) * (hy + 1.0)};
}

}  // namespace

VenueCase loadVenueCase(const config::Node& root) {
  VenueCase c;
  c.file = root.file();
  c.name = root.get<std::string>("name");
  c.description = root.getOr<std::string>("description", "");
  c.field = config::resolveAgainst(c.file, "field", root.getOr<std::string>("field", "msl"));
  c.camera =
      config::resolveAgainst(c.file, "camera", root.getOr<std::string>("camera", "omni_sim"));
  const config::Node cam = config::Node::loadFile(config::resolvePreset("camera", c.camera));
  c.render = camera::loadRenderParams(cam.child("render"));
  if (const std::optional<config::Node> colours = root.childIf("colours")) {
    const std::vector<std::pair<std::string, camera::Bgr*>> keys = {
        {"carpet_bgr", &c.render.carpet},
        {"line_bgr", &c.render.line},
        {"outside_floor_bgr", &c.render.outside_floor},
        {"hall_bgr", &c.render.hall},
        {"ball_bgr", &c.render.ball},
        {"robot_bgr", &c.render.robot},
        {"goal_white_bgr", &c.render.goal_white}};
    for (const auto& [key, target] : keys) {
      if (colours->has(key)) *target = loadBgr(*colours, key);
    }
    colours->rejectUnknownKeys();
  }
  if (root.has("light_spots")) {
    for (const config::Node& s : root.children("light_spots")) {
      camera::LightSpot spot;
      spot.position = loadVec2(s, "position", 100.0);
      spot.radius = s.get<double>("radius", 0.05, 50.0);
      spot.gain = s.get<double>("gain", 0.0, 3.0);
      s.rejectUnknownKeys();
      c.render.lighting.spots.push_back(spot);
    }
  }
  if (const std::optional<config::Node> realism = root.childIf("realism")) {
    c.render.realism = camera::loadRealismParams(*realism);
  }
  if (const std::optional<config::Node> mirror = root.childIf("mirror")) {
    c.mirror = loadMirror(*mirror);
  }
  for (const config::Node& s : root.children("spots")) {
    VenueSpot spot;
    spot.position = loadVec2(s, "position", 50.0);
    spot.headings_deg = s.getList<double>("headings_deg");
    if (spot.headings_deg.empty()) s.fail("headings_deg", "at least one heading");
    s.rejectUnknownKeys();
    c.spots.push_back(spot);
  }
  if (c.spots.empty()) root.fail("spots", "at least one spot");
  if (root.has("ball")) c.ball = loadVec2(root, "ball", 50.0);
  if (root.has("robots")) {
    for (const config::Node& r : root.children("robots")) {
      c.robots.push_back(loadVec2(r, "position", 50.0));
      r.rejectUnknownKeys();
    }
  }
  c.people = root.getOr<int>("people", 0, 0, 100);
  c.seed = static_cast<std::uint32_t>(root.getOr<int>("seed", 1, 0, 1 << 30));
  if (const std::optional<config::Node> expect = root.childIf("expect")) {
    for (const std::string& key : expect->keys())
      c.expect[key] = expect->get<double>(key);
  }
  root.rejectUnknownKeys();
  return c;
}

VenueCase loadVenueCase(const std::string& path) {
  return loadVenueCase(config::Node::loadFile(path));
}

camera::MirrorModel venueMirror(const VenueCase& c) {
  camera::MirrorParams p = camera::loadCameraPreset(c.camera).mirror.params();
  p.centre += c.mirror.centre_shift;
  p.axis_offset = c.mirror.axis_offset;
  if (c.mirror.law == "tan") {
    const double tilt = c.mirror.tilt_deg * kDeg;
    const double towards = c.mirror.tilt_bearing_deg * kDeg;
    // Up to where the steepest sector's angle stays 0.05 rad short of the horizon, at most the
    // mirror's edge.
    const double end = std::min(p.outer_radius, (kPi / 2 - 0.05 - std::abs(tilt)) / c.mirror.rate);
    camera::CalibrationTableParams t;
    const double start = std::max(1.0, p.self_radius);
    for (double r = start; r < end; r += 1.0)
      t.radii.push_back(r);
    constexpr int kSectors = 72;
    for (int s = 0; s < kSectors; ++s) {
      const double b = -kPi + 2 * kPi * (s + 1) / kSectors;
      t.sector_bearings.push_back(b);
      std::vector<double> d;
      for (double r : t.radii)
        d.push_back(c.mirror.scale * std::tan(c.mirror.rate * r + tilt * std::cos(b - towards)));
      t.distances.push_back(d);
    }
    p.distance = camera::DistanceFunction(t);
    p.useful_radius = std::min(p.useful_radius, t.radii.back());
  }
  return camera::MirrorModel(p);
}

camera::FrameView RenderedVenue::view(std::size_t frame) const {
  return {frames.at(frame).yuyv.data(), mirror.width(), mirror.height(), 2 * mirror.width(),
          camera::PixelFormat::kYuyv};
}

RenderedVenue renderVenue(const VenueCase& c) {
  RenderedVenue out{c, venueMirror(c), field::loadFieldPreset(c.field), {}, {}};
  std::mt19937 rng(c.seed);
  const std::vector<camera::Bgr> shirts = {{235, 235, 235}, {30, 120, 240}, {40, 160, 60},
                                           {40, 40, 200},   {180, 80, 30},  {40, 200, 230},
                                           {200, 200, 200}, {20, 20, 20}};
  for (int i = 0; i < c.people; ++i) {
    const Vec2 at = placeInHall(out.field, rng);
    addPerson(at, shirts[static_cast<std::size_t>(i) % shirts.size()], out.clutter);
  }
  camera::RenderParams params = c.render;
  params.noise_seed = c.seed;
  params.realism.seed = c.seed;
  camera::SimRenderer renderer(out.mirror, out.field, params);
  camera::SimScene scene;
  scene.boxes = out.clutter;
  for (std::size_t i = 0; i < c.robots.size(); ++i) {
    camera::SimRobot r;
    r.position = c.robots[i];
    r.teammate = i % 2 == 0;
    scene.robots.push_back(r);
  }
  if (c.ball) scene.ball = camera::SimBall{*c.ball, 0.11};
  std::uint64_t number = 0;
  for (std::size_t s = 0; s < c.spots.size(); ++s) {
    for (double heading : c.spots[s].headings_deg) {
      VenueFrame f;
      f.pose = {c.spots[s].position.x(), c.spots[s].position.y(),
                geometry::normalizeAngle(heading * kDeg)};
      f.spot = static_cast<int>(s);
      scene.robot = f.pose;
      scene.frame_number = number++;
      renderer.render(scene, f.yuyv);
      if (c.ball) {
        const Vec2 b = geometry::pointFieldToRobot(f.pose, *c.ball);
        const std::optional<Vec2> px = out.mirror.robotPointToImage({b.x(), b.y(), 0.11});
        if (px && out.mirror.zone(*px) == camera::MirrorZone::kUseful) f.ball_pixel = *px;
      }
      out.frames.push_back(std::move(f));
    }
  }
  return out;
}

std::vector<std::string> writeVenue(const RenderedVenue& venue, const std::string& folder) {
  namespace fs = std::filesystem;
  fs::create_directories(folder);
  std::vector<std::string> paths;
  std::ofstream truth(fs::path(folder) / "truth.yaml");
  truth << "# Truth of the rendered venue case '" << venue.spec.name
        << "' (for scoring only; the frames are what a team has).\n";
  truth << fmt::format("case: {}\nfield: {}\n", venue.spec.name, venue.spec.field);
  const camera::MirrorParams& m = venue.mirror.params();
  truth << fmt::format(
      "mirror: {{law: {}, centre: [{:.3f}, {:.3f}], axis_offset: [{:.4f}, {:.4f}], tilt_deg: "
      "{}, tilt_bearing_deg: {}}}\n",
      venue.spec.mirror.law, m.centre.x(), m.centre.y(), m.axis_offset.x(), m.axis_offset.y(),
      venue.spec.mirror.tilt_deg, venue.spec.mirror.tilt_bearing_deg);
  if (venue.spec.ball) {
    truth << fmt::format("ball: [{:.3f}, {:.3f}]\n", venue.spec.ball->x(), venue.spec.ball->y());
  }
  truth << "frames:\n";
  for (std::size_t i = 0; i < venue.frames.size(); ++i) {
    const VenueFrame& f = venue.frames[i];
    const std::string name = fmt::format("frame_{:02d}.png", i);
    const fs::path path = fs::path(folder) / name;
    camera::writeImage(path.string(), camera::toBgrImage(venue.view(i)));
    paths.push_back(path.string());
    truth << fmt::format("  - {{file: {}, spot: {}, pose: [{:.4f}, {:.4f}, {:.5f}]", name, f.spot,
                         f.pose.x, f.pose.y, f.pose.phi);
    if (f.ball_pixel) {
      truth << fmt::format(", ball_pixel: [{:.2f}, {:.2f}]", f.ball_pixel->x(), f.ball_pixel->y());
    }
    truth << "}\n";
  }
  truth.close();
  if (!truth) throw std::runtime_error("cannot write " + folder + "/truth.yaml");
  return paths;
}

}  // namespace fieldline::venue
