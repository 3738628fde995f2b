#include "services/fusion/pose_memory.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>

#include <Eigen/Cholesky>

#include "common/process/state_file.hpp"

namespace fieldline::fusion {
namespace {

constexpr const char* kMagic = "fieldline-fusion-pose 1";
constexpr const char* kKeys[] = {"robot", "field",      "supervisor",    "saved_steady_us",
                                 "pose",  "covariance", "twin_ambiguous"};

std::string num(double v) {
  return fmt::format("{:.17g}", v);
}

[[noreturn]] void bad(std::size_t line, const std::string& what) {
  throw std::runtime_error("saved pose line " + std::to_string(line) + ": " + what);
}

// The values of line `index` (0-based), which must start with kKeys[index - 1].
std::istringstream fields(const std::vector<std::string>& lines, std::size_t index) {
  const std::string key = kKeys[index - 1];
  if (lines[index].rfind(key + " ", 0) != 0) bad(index + 1, "expected '" + key + "'");
  return std::istringstream(lines[index].substr(key.size() + 1));
}

template <typename... T>
void readAll(std::istringstream in, std::size_t line, T&... out) {
  ((in >> out), ...);
  if (in.fail()) bad(line, "expected " + std::to_string(sizeof...(T)) + " values");
  std::string rest;
  if (in >> rest) bad(line, "unexpected '" + rest + "'");
}

}  // namespace

std::string encodeSavedPose(const SavedPose& s) {
  const Eigen::Matrix3d& c = s.covariance;
  return fmt::format(
      "{}\nrobot {}\nfield {}\nsupervisor {}\nsaved_steady_us {}\npose {} {} {}\n"
      "covariance {} {} {} {} {} {}\ntwin_ambiguous {}\n",
      kMagic, s.robot_id, s.field, s.supervisor.empty() ? "-" : s.supervisor, s.saved_steady_us,
      num(s.pose.x), num(s.pose.y), num(s.pose.phi), num(c(0, 0)), num(c(0, 1)), num(c(0, 2)),
      num(c(1, 1)), num(c(1, 2)), num(c(2, 2)), s.twin_ambiguous ? 1 : 0);
}

SavedPose decodeSavedPose(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);)
    lines.push_back(l);
  if (lines.empty() || lines[0] != kMagic)
    bad(1, "not a saved pose (no '" + std::string(kMagic) + "')");
  if (lines.size() != 8)
    bad(lines.size(), "expected 8 lines, found " + std::to_string(lines.size()));
  SavedPose s;
  readAll(fields(lines, 1), 2, s.robot_id);
  // Free text (a field's YAML path may hold spaces).
  s.field = fields(lines, 2).str();
  s.supervisor = fields(lines, 3).str();
  if (s.supervisor == "-") s.supervisor.clear();
  readAll(fields(lines, 4), 5, s.saved_steady_us);
  readAll(fields(lines, 5), 6, s.pose.x, s.pose.y, s.pose.phi);
  Eigen::Matrix3d& c = s.covariance;
  readAll(fields(lines, 6), 7, c(0, 0), c(0, 1), c(0, 2), c(1, 1), c(1, 2), c(2, 2));
  c(1, 0) = c(0, 1);
  c(2, 0) = c(0, 2);
  c(2, 1) = c(1, 2);
  int ambiguous = 0;
  readAll(fields(lines, 7), 8, ambiguous);
  if (ambiguous != 0 && ambiguous != 1) bad(8, "twin_ambiguous must be 0 or 1");
  s.twin_ambiguous = ambiguous == 1;
  if (!(std::isfinite(s.pose.x) && std::isfinite(s.pose.y) && std::isfinite(s.pose.phi)))
    bad(6, "pose not finite");
  if (!c.allFinite() || Eigen::LLT<Eigen::Matrix3d>(c).info() != Eigen::Success)
    bad(7, "covariance not finite or not positive definite");
  return s;
}

void writeSavedPoseFile(const std::string& path, const SavedPose& saved) {
  process::writeStateFile(path, encodeSavedPose(saved));
}

std::optional<SavedPose> readSavedPoseFile(const std::string& path) {
  const std::optional<std::string> text = process::readStateFile(path);
  if (!text) return std::nullopt;
  try {
    return decodeSavedPose(*text);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
}

std::string resumeRefusal(const SavedPose& saved, int robot_id, const std::string& field,
                          const std::string& supervisor, Utime steady_now_us, double max_age_s,
                          double& age_s) {
  if (saved.robot_id != robot_id) return "resume_other_robot";
  if (saved.field != field) return "resume_other_field";
  if (saved.supervisor != supervisor) return "resume_new_run";
  age_s = static_cast<double>(steady_now_us - saved.saved_steady_us) * 1e-6;
  if (age_s < 0.0) return "resume_from_future";
  if (!(age_s <= max_age_s)) return "resume_stale";
  return {};
}

}  // namespace fieldline::fusion
