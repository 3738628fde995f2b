#include "services/world_sim/world_snapshot.hpp"

#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

#include "common/process/state_file.hpp"

namespace fieldline::world_sim {
namespace {

constexpr const char* kMagic = "fieldline-world-snapshot 1";

std::string num(double v) {
  return fmt::format("{:.17g}", v);
}

[[noreturn]] void bad(int line, const std::string& what) {
  throw std::runtime_error("world snapshot line " + std::to_string(line) + ": " + what);
}

// The words after `key` on a line that must start with it.
std::istringstream fields(const std::string& text, const std::string& key, int line) {
  if (text.rfind(key + " ", 0) != 0) bad(line, "expected '" + key + "'");
  return std::istringstream(text.substr(key.size() + 1));
}

template <typename... T>
void readAll(std::istringstream& in, int line, T&... out) {
  ((in >> out), ...);
  if (in.fail()) bad(line, "expected " + std::to_string(sizeof...(T)) + " values");
  std::string rest;
  if (in >> rest) bad(line, "unexpected '" + rest + "'");
}

}  // namespace

std::string encodeSnapshot(const WorldSnapshot& s) {
  std::string out = std::string(kMagic) + "\n";
  out += "scenario " + s.scenario + "\n";
  out += fmt::format("saved_utime {}\nsteps {}\nevents {} {}\n", s.saved_utime, s.steps,
                     s.next_kick, s.next_kidnap);
  out += fmt::format("ball {} {} {} {}\n", num(s.ball.position.x()), num(s.ball.position.y()),
                     num(s.ball.velocity.x()), num(s.ball.velocity.y()));
  for (const RobotTruth& r : s.robots) {
    out += fmt::format("robot {} {} {} {} {} {} {}", r.id, num(r.pose.x), num(r.pose.y),
                       num(r.pose.phi), num(r.velocity.x()), num(r.velocity.y()), num(r.omega));
    for (const auto* v : {&r.wheel_commands, &r.wheel_speeds, &r.wheel_angles}) {
      for (Eigen::Index i = 0; i < v->size(); ++i)
        out += " " + num((*v)[i]);
    }
    out += fmt::format(" {} {} {}\n", r.kidnaps, r.contact_steps, r.in_contact ? 1 : 0);
  }
  out += "rng " + s.rng + "\n";
  if (!s.supervisor.empty()) out += "supervisor " + s.supervisor + "\n";
  return out;
}

WorldSnapshot decodeSnapshot(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);)
    lines.push_back(l);
  if (lines.empty() || lines[0] != kMagic)
    bad(1, "not a world snapshot (no '" + std::string(kMagic) + "')");
  if (lines.size() < 7) bad(static_cast<int>(lines.size()), "truncated");
  WorldSnapshot s;
  if (lines[1].rfind("scenario ", 0) != 0) bad(2, "expected 'scenario'");
  s.scenario = lines[1].substr(9);
  {
    auto f = fields(lines[2], "saved_utime", 3);
    readAll(f, 3, s.saved_utime);
  }
  {
    auto f = fields(lines[3], "steps", 4);
    readAll(f, 4, s.steps);
    if (s.steps < 0) bad(4, "negative step count");
  }
  {
    auto f = fields(lines[4], "events", 5);
    readAll(f, 5, s.next_kick, s.next_kidnap);
  }
  {
    auto f = fields(lines[5], "ball", 6);
    double x = 0, y = 0, vx = 0, vy = 0;
    readAll(f, 6, x, y, vx, vy);
    s.ball.position = {x, y};
    s.ball.velocity = {vx, vy};
  }
  std::size_t i = 6;
  for (; i < lines.size() && lines[i].rfind("robot ", 0) == 0; ++i) {
    const int line = static_cast<int>(i + 1);
    auto f = fields(lines[i], "robot", line);
    // 7 pose values, three per wheel (command, speed, angle), 3 counters: the wheel count
    // follows from the number of words.
    std::size_t words = 0;
    {
      std::istringstream count(f.str());
      for (std::string w; count >> w;)
        ++words;
    }
    const std::size_t wheel_words = words >= 10 ? words - 10 : 0;
    const auto wheels = static_cast<Eigen::Index>(wheel_words / 3);
    if (wheel_words % 3 != 0 || wheels < robot::kMinWheels || wheels > robot::kMaxWheels) {
      bad(line, "expected 7 pose values, 3 per wheel (3 or 4 wheels) and 3 counters, found " +
                    std::to_string(words) + " values");
    }
    RobotTruth r;
    double vx = 0, vy = 0;
    int contact = 0;
    f >> r.id >> r.pose.x >> r.pose.y >> r.pose.phi >> vx >> vy >> r.omega;
    for (auto* v : {&r.wheel_commands, &r.wheel_speeds, &r.wheel_angles}) {
      v->resize(wheels);
      for (Eigen::Index k = 0; k < wheels; ++k)
        f >> (*v)[k];
    }
    r.wheel_slip = robot::WheelVector::Zero(wheels);
    readAll(f, line, r.kidnaps, r.contact_steps, contact);
    r.velocity = {vx, vy};
    r.in_contact = contact != 0;
    s.robots.push_back(r);
  }
  if (i >= lines.size() || lines[i].rfind("rng ", 0) != 0)
    bad(static_cast<int>(i + 1), "expected 'rng'");
  s.rng = lines[i].substr(4);
  if (++i < lines.size() && lines[i].rfind("supervisor ", 0) == 0)
    s.supervisor = lines[i].substr(11);
  return s;
}

std::optional<WorldSnapshot> readSnapshotFile(const std::string& path) {
  const std::optional<std::string> text = process::readStateFile(path);
  if (!text) return std::nullopt;
  try {
    return decodeSnapshot(*text);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
}

}  // namespace fieldline::world_sim
