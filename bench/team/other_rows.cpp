#include "bench/team/other_rows.hpp"

#include <algorithm>
#include <cmath>

#include "common/geometry/geometry.hpp"

namespace fieldline::team_bench {
namespace {

// Why a robot's ball is not in a scored team picture (--others).
const char* leftOutBecause(const teamcomm::TeamPicture& picture,
                           const teamcomm::TeamBallResult& result,
                           const perception::TeammateState& m, int id, Utime now,
                           const teamcomm::PictureOptions& options) {
  const auto has = [](const std::vector<int>& v, int x) {
    return std::find(v.begin(), v.end(), x) != v.end();
  };
  const teamcomm::Report* report = picture.report(id);
  if (!report) return "unheard";
  if (!m.present) return "absent";
  if (report->robot.status != perception::LocalizationStatus::kTracking) return "not_tracking";
  if (!report->ball.valid) return "no_ball";
  if (now - report->ball.last_seen_utime > options.ball_timeout_us) return "timed_out";
  if (has(result.superseded, id)) return "superseded";
  if (has(result.mirrored, id)) return "mirrored";
  return "gate";
}

}  // namespace

const char* otherRowsHeader() {
  return "observer,t,robot,reason,ball_x,ball_y,true_range,true_bearing,occlusion_gap,"
         "since_sighting_ms,own_valid,held_since_seen_ms,held_speed,held_err,held_sigma\n";
}

// Every robot the team ball did not use in a scored picture, for --others: why, where it is, when
// its camera last saw a ball and how good its own newest valid estimate (held to now) is.
void writeOtherRows(std::FILE* others_csv, const std::vector<eval::TruthSample>& truth,
                    const std::map<int, RobotLog>& logs, int observer, Utime now, Utime start,
                    const Eigen::Vector2d& t, const teamcomm::TeamBallResult& result,
                    const perception::TeamState& state, const teamcomm::TeamPicture& picture,
                    const teamcomm::PictureOptions& options, const SightingRows& bodies) {
  for (const auto& [id, r] : logs) {
    if (std::find(result.used.begin(), result.used.end(), id) != result.used.end()) continue;
    const perception::TeammateState& m = state.robots[static_cast<std::size_t>(id - 1)];
    eval::TruthRobot tr;
    double bx = 0, by = 0;
    if (!eval::truthAt(truth, now, id, tr, &bx, &by)) continue;
    const auto seen = std::upper_bound(r.seen.begin(), r.seen.end(), now);
    const double since_seen_ms =
        seen == r.seen.begin() ? -1.0 : static_cast<double>(now - *std::prev(seen)) / 1e3;
    // Its newest valid BALL_STATE that had arrived by now (on its own bus), held to now.
    const Timed* held = nullptr;
    for (auto it = r.balls.rbegin(); it != r.balls.rend(); ++it) {
      if (it->received <= now && it->ball.valid) {
        held = &*it;
        break;
      }
    }
    const Timed* newest = newestAt(r.balls, now);
    std::fprintf(others_csv, "%d,%.3f,%d,%s,%.3f,%.3f,%.3f,%.3f,%.4f,%.1f,%d", observer,
                 static_cast<double>(now - start) / 1e6, id,
                 leftOutBecause(picture, result, m, id, now, options), t.x(), t.y(),
                 std::hypot(t.x() - tr.x, t.y() - tr.y),
                 geometry::normalizeAngle(std::atan2(t.y() - tr.y, t.x() - tr.x) - tr.phi),
                 bodies.occlusionGap(now, id, tr, t.x(), t.y()), since_seen_ms,
                 newest && newest->ball.valid ? 1 : 0);
    if (held) {
      const perception::BallEstimate& b = held->ball;
      std::fprintf(others_csv, ",%.1f,%.3f,%.4f,%.4f\n",
                   static_cast<double>(now - b.last_seen_utime) / 1e3, std::hypot(b.vx, b.vy),
                   std::hypot(b.x - t.x(), b.y - t.y()), std::sqrt(0.5 * b.covariance.trace()));
    } else {
      std::fprintf(others_csv, ",,,,\n");
    }
  }
}

}  // namespace fieldline::team_bench
