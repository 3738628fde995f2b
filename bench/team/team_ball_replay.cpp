// fieldline-team-ball-replay: the team ball of a recorded match, recomputed. Reads a recording of
// bench/fusion/record_match.sh (robotN.lcm with ROBOT_STATE and BALL_STATE, sim.lcm with
// SIM_WORLD; every robot on the recorder's clock), plays each robot's team link as teamcomm does
// (own estimates as they arrived; each teammate's newest fresh estimates in a packet every
// 1/send_rate s, arriving `--delay-ms` later), asks teamcomm's TeamPicture for the team ball at
// the publish rate, and scores it against the truth as fieldline-eval does: the mean error of
// the team ball, each robot's own ball, and the consistency (NEES) of both. So a change to the
// team ball's fusion is measured on the same sightings, without running the team again.
//
//   fieldline-team-ball-replay /tmp/rec_match [--gate-chi2 9.21] [--no-pose-spread] ...
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <Eigen/LU>

#include "bench/team/other_rows.hpp"
#include "bench/team/robot_log.hpp"
#include "bench/team/sighting_rows.hpp"
#include "common/bus/log_file.hpp"
#include "common/cli/cli.hpp"
#include "common/geometry/geometry.hpp"
#include "common/msg/estimates.hpp"
#include "common/time/offset_clock.hpp"
#include "teamcomm/team_picture.hpp"
#include "tools/eval/evaluation.hpp"
#include "tools/eval/sim_truth.hpp"
#include "tools/eval/team_ball.hpp"
#include "tools/eval/team_ball_budget.hpp"
#include "tools/recording/clock_model.hpp"

using namespace fieldline;
using team_bench::newestAt;
using team_bench::RobotLog;
using team_bench::Timed;

namespace {

// Chi-square with 2 degrees of freedom: the central 95 % of single-sample NEES values.
constexpr double kNees2Low = 0.0506;
constexpr double kNees2High = 7.3778;

struct Score {
  double sum = 0.0;
  std::size_t n = 0;
  std::size_t nees_n = 0, nees_in = 0, nees_low = 0;
  double nees_sum = 0.0;
  std::vector<double> nees_all;
  void add(const Eigen::Vector2d& error, const Eigen::Matrix2d& covariance) {
    sum += error.norm();
    ++n;
    if (covariance.determinant() > 0.0) {
      const double nees = error.dot(covariance.inverse() * error);
      ++nees_n;
      nees_sum += nees;
      if (nees >= kNees2Low && nees <= kNees2High) ++nees_in;
      if (nees < kNees2Low) ++nees_low;
      nees_all.push_back(nees);
    }
  }
  double mean() const { return n ? sum / static_cast<double>(n) : -1.0; }
  double inBand() const {
    return nees_n ? static_cast<double>(nees_in) / static_cast<double>(nees_n) : -1.0;
  }
  double neesMean() const { return nees_n ? nees_sum / static_cast<double>(nees_n) : -1.0; }
  // "below band 3 %, NEES p50 1.2 p95 6.0"
  std::string neesSpread() const {
    if (nees_all.empty()) return "no NEES";
    std::vector<double> v = nees_all;
    std::sort(v.begin(), v.end());
    return fmt::format("below band {:.0f} %, NEES p50 {:.2f} p95 {:.1f}",
                       100.0 * static_cast<double>(nees_low) / static_cast<double>(nees_n),
                       v[v.size() / 2], v[v.size() * 95 / 100]);
  }
};

struct ReplayOptions {
  std::string dir;
  double settle_s = 5.0;
  bool publish_on_ball = false;
  double send_rate_hz = 20.0, publish_rate_hz = 10.0, delay_ms = 1.5, fresh_s = 0.3;
  double max_send_rate_hz = 30.0;
  teamcomm::PictureOptions picture;
  double max_prediction_s = 0.5;
  double superseded_after_s = 0.09;  // config/team/sim_team.yaml
  std::string csv_path, sightings_path, pictures_path, reporters_path, others_path;
  bool budget = false;

  void addTo(cli::App& app) {
    app.add_option("recording", dir, "Recording directory (sim.lcm, robot1.lcm ...)")->required();
    app.add_option("--settle", settle_s, "Seconds after the first state not scored")
        ->capture_default_str();
    app.add_flag("--publish-on-ball", publish_on_ball,
                 "Each picture at the first own BALL_STATE after its tick");
    app.add_option("--send-rate", send_rate_hz, "Team packets per second")->capture_default_str();
    app.add_option("--max-send-rate", max_send_rate_hz,
                   "At most this many per second, a new ball at once (= --send-rate: on the timer "
                   "only)")
        ->capture_default_str();
    app.add_option("--publish-rate", publish_rate_hz, "Team pictures per second")
        ->capture_default_str();
    app.add_option("--delay-ms", delay_ms, "Network delay of a team packet, ms")
        ->capture_default_str();
    app.add_option("--fresh", fresh_s, "Own estimates older than this are not sent, s")
        ->capture_default_str();
    app.add_option("--gate-chi2", picture.gate_chi2, "Team ball consistency gate")
        ->capture_default_str();
    app.add_option("--ball-speed-sigma", picture.ball_speed_sigma_mps,
                   "Unmodelled ball speed while predicting a ball to the picture's time, m/s")
        ->capture_default_str();
    app.add_option("--max-prediction", max_prediction_s, "Predictions reach at most this far, s")
        ->capture_default_str();
    app.add_option(
           "--superseded-after", superseded_after_s,
           "A ball seen this much longer ago than a contradicting one is left out, s (0: off)")
        ->capture_default_str();
    app.add_option("--radial-floor", picture.ball_radial_floor_per_m2,
                   "Floor of a ball's sigma along the line of sight per squared metre of range")
        ->capture_default_str();
    app.add_option("--min-ball-variance", picture.min_ball_variance,
                   "Floor of a ball's position variance, m^2")
        ->check(cli::PositiveNumber)
        ->capture_default_str();
    app.add_option("--stamp-sigma", picture.ball_stamp_sigma_s,
                   "The stamp term every BALL_STATE carries, common to the reporters (fusion's "
                   "ball.stamp_sigma_s), s")
        ->check(cli::Range(0.0, 1.0))
        ->capture_default_str();
    app.add_option("--carry-track", picture.carry_track,
                   "Combine the previous team ball with each picture's (covariance intersection)")
        ->capture_default_str();
    app.add_option("--carry-speed-sigma", picture.carry_speed_sigma_mps,
                   "The carried team ball's growth while the ball rests, m/s")
        ->capture_default_str();
    addOutputs(app);
  }

  void addOutputs(cli::App& app) {
    app.add_option("--csv", csv_path,
                   "Write every scored own ball (robot, t, error, range, speeds, sigma, pose "
                   "error) here");
    app.add_option("--sightings", sightings_path,
                   "Write every visible VISION_BALL against the truth (robot frame: range, radial "
                   "and tangential error, the detector's sigmas, turn rate, the ball's bearing "
                   "rate, how near a body in front comes to hiding it, fusion's heading error "
                   "at the stamp) here");
    app.add_flag("--budget", budget,
                 "Print the team ball's error by class of picture (the ball resting or rolling; "
                 "one reporter near or far, or more; a resting ball its reporters say rolls)");
    app.add_option("--pictures", pictures_path,
                   "Write every scored team picture (observer, t, team ball error and sigma, each "
                   "robot's ball error and range) here");
    app.add_option(
        "--others", others_path,
        "Write every robot the team ball did not use in every scored team picture (why: "
        "unheard, absent, not tracking, no valid ball in its packet, timed out, "
        "superseded, gate; its true range, the time since its camera last saw a ball, "
        "and its own newest valid BALL_STATE held to the picture's time; how near a body comes to "
        "hiding the ball from it, with --sightings) here");
    app.add_option("--reporters", reporters_path,
                   "Write every reporter's ball in every scored team picture (its BALL_STATE's "
                   "age, its error at its own stamp, predicted to the picture's time and held "
                   "there, whether the team ball used it) here");
  }
};

std::vector<eval::TruthSample> readTruth(const std::string& dir, team_bench::SightingRows& rows) {
  std::vector<eval::TruthSample> truth;
  bus::LogReader log(dir + "/sim.lcm");
  world_state_t w;
  while (log.next(bus::channels::kSimWorld, w)) {
    eval::appendTruth(truth, w);
    rows.addWorld(w);
  }
  return truth;
}

// The true ball at `t` (false: outside the truth).
bool ballAt(const std::vector<eval::TruthSample>& truth, Utime t, Eigen::Vector2d& out) {
  eval::TruthRobot unused;
  double x = 0, y = 0;
  if (!eval::truthAt(truth, t, truth.front().robots.begin()->first, unused, &x, &y)) return false;
  out = {x, y};
  return true;
}

// The ROBOT_STATE (of the newest 64 received) whose stamp is nearest `t`, within 25 ms.
const perception::RobotEstimate* stateNear(const std::vector<Timed>& states, Utime t) {
  const Timed* nearest = nullptr;
  for (auto it = states.rbegin(); it != states.rend() && it - states.rbegin() < 64; ++it) {
    if (!nearest || std::abs(it->robot.utime - t) < std::abs(nearest->robot.utime - t))
      nearest = &*it;
  }
  return nearest && std::abs(nearest->robot.utime - t) <= 25'000 ? &nearest->robot : nullptr;
}

// Every robot's estimates (robotN.lcm; missing or empty files are skipped); with `sightings`,
// every visible VISION_BALL is written there against the truth.
std::map<int, RobotLog> readRobotLogs(const std::string& dir,
                                      const std::vector<eval::TruthSample>& truth,
                                      team_bench::SightingRows* sightings) {
  std::map<int, RobotLog> logs;
  for (int id = 1; id <= perception::kTeamSize; ++id) {
    const std::string path = dir + "/robot" + std::to_string(id) + ".lcm";
    if (!std::filesystem::exists(path) || std::filesystem::file_size(path) == 0) continue;
    // The robot's stamps on the recorder's (the truth's) clock: a recording of robots on their
    // own clocks (sim_team's offsets of +-0.5 s) is otherwise scored against the wrong truth.
    ClockError clock;
    if (const auto models = recording::estimateClocks(path); models.count(id) > 0)
      clock = models.at(id).error;
    bus::LogReader log(path);
    bus::LogEvent e;
    RobotLog& r = logs[id];
    while (log.nextEvent(e)) {
      const int size = static_cast<int>(e.data.size());
      if (e.channel == bus::channels::kRobotState.name) {
        robot_state_t m;
        if (m.decode(e.data.data(), 0, size) != size) continue;
        perception::RobotEstimate robot = msg::fromMessage(m);
        robot.utime = ownToTruth(clock, robot.utime);
        r.robots.push_back({e.timestamp, robot, {}});
      } else if (e.channel == bus::channels::kVisionBall.name) {
        ball_observation_t m;
        if (m.decode(e.data.data(), 0, size) != size) continue;
        perception::BallSighting sighting = msg::fromMessage(m);
        sighting.utime = ownToTruth(clock, sighting.utime);
        if (sighting.visible) r.seen.push_back(sighting.utime);
        if (sightings) sightings->write(truth, id, sighting, stateNear(r.robots, sighting.utime));
      } else if (e.channel == bus::channels::kBallState.name) {
        ball_state_t m;
        if (m.decode(e.data.data(), 0, size) != size) continue;
        perception::BallEstimate ball = msg::fromMessage(m);
        ball.utime = ownToTruth(clock, ball.utime);
        ball.last_seen_utime = ownToTruth(clock, ball.last_seen_utime);
        r.balls.push_back({e.timestamp, {}, ball});
      }
    }
  }
  return logs;
}

// The recording's scored span: `start` (first ROBOT_STATE), `end` (last one, within the truth).
struct Span {
  Utime start = 0, scored_from = 0, end = 0;
};

Span recordingSpan(const std::map<int, RobotLog>& logs, const std::vector<eval::TruthSample>& truth,
                   double settle_s) {
  Utime start = std::numeric_limits<Utime>::max(), end = 0;
  for (const auto& [id, r] : logs) {
    if (r.robots.empty()) continue;
    start = std::min(start, r.robots.front().received);
    end = std::max(end, r.robots.back().received);
  }
  end = std::min(end, truth.back().utime);
  return {start, start + static_cast<Utime>(settle_s * 1e6), end};
}

// One scored own ball with the robot's pose (and its error) at that time, for --csv.
void writeOwnBallRow(std::FILE* csv, const std::vector<eval::TruthSample>& truth, int id,
                     const RobotLog& r, const Timed& b, const Eigen::Vector2d& t,
                     const Eigen::Vector2d& error, Utime start) {
  eval::TruthRobot tr;
  double unused_x = 0, unused_y = 0;
  eval::truthAt(truth, b.ball.utime, id, tr, &unused_x, &unused_y);
  // The ball's speed needs the truth 100 ms later: NaN at the end of the recording.
  Eigen::Vector2d t_later;
  const double ball_speed = ballAt(truth, b.ball.utime + 100'000, t_later)
                                ? (t_later - t).norm() / 0.1
                                : std::numeric_limits<double>::quiet_NaN();
  const Timed* pose = nullptr;
  for (const Timed& p : r.robots) {
    if (p.robot.utime > b.ball.utime) break;
    pose = &p;
  }
  const Eigen::Vector2d to_ball = t - Eigen::Vector2d(tr.x, tr.y);
  const Eigen::Vector2d along = to_ball.normalized();
  const Eigen::Vector2d across(-along.y(), along.x());
  double pose_err = -1, heading_err = 0, robot_sigma = 0, heading_sigma = 0, robot_speed = 0;
  int status = -1;
  if (pose) {
    pose_err = std::hypot(pose->robot.pose.x - tr.x, pose->robot.pose.y - tr.y);
    heading_err = std::remainder(pose->robot.pose.phi - tr.phi, 2 * M_PI) * 180 / M_PI;
    robot_sigma = std::sqrt(0.5 * pose->robot.covariance.topLeftCorner<2, 2>().trace());
    heading_sigma = std::sqrt(pose->robot.covariance(2, 2)) * 180 / M_PI;
    robot_speed = std::hypot(pose->robot.vx, pose->robot.vy);
    status = static_cast<int>(pose->robot.status);
  }
  std::fprintf(csv, "%d,%.3f,%.4f,%.4f,%.4f,%.3f,%.3f,%.3f,%.4f,%.3f,%.4f,%.3f,%.4f,%.3f,%d\n", id,
               static_cast<double>(b.ball.utime - start) / 1e6, error.norm(), error.dot(along),
               error.dot(across), to_ball.norm(), ball_speed, robot_speed,
               std::sqrt(0.5 * b.ball.covariance.trace()),
               static_cast<double>(b.ball.utime - b.ball.last_seen_utime) / 1e6, pose_err,
               heading_err, robot_sigma, heading_sigma, status);
}

// Own balls, as the evaluation scores them (every valid BALL_STATE after the settle time).
std::map<int, Score> scoreOwnBalls(const std::map<int, RobotLog>& logs,
                                   const std::vector<eval::TruthSample>& truth, const Span& span,
                                   std::FILE* csv) {
  std::map<int, Score> own;
  for (const auto& [id, r] : logs) {
    for (const Timed& b : r.balls) {
      if (!b.ball.valid || b.ball.utime < span.scored_from || b.ball.utime > span.end) continue;
      Eigen::Vector2d t;
      if (!ballAt(truth, b.ball.utime, t)) continue;
      const Eigen::Vector2d error = Eigen::Vector2d(b.ball.x, b.ball.y) - t;
      own[id].add(error, b.ball.covariance);
      if (csv) writeOwnBallRow(csv, truth, id, r, b, t, error, span.start);
    }
  }
  return own;
}

// The team link's timing, from the options.
struct LinkTiming {
  Utime send_period, publish_period, delay, fresh;
  std::map<int, Utime> phase;  // each robot's send clock phase
};

LinkTiming linkTiming(const ReplayOptions& o, const std::map<int, RobotLog>& logs) {
  LinkTiming link{static_cast<Utime>(1e6 / o.send_rate_hz),
                  static_cast<Utime>(1e6 / o.publish_rate_hz),
                  static_cast<Utime>(o.delay_ms * 1e3),
                  static_cast<Utime>(o.fresh_s * 1e6),
                  {}};
  std::mt19937 rng(7);
  for (const auto& [id, r] : logs)
    link.phase[id] = std::uniform_int_distribution<Utime>(0, link.send_period - 1)(rng);
  return link;
}

// Each robot's send times as teamcomm schedules them: a send period after the last packet, or
// at once for a new valid BALL_STATE when the last is at least the shortest interval old.
std::map<int, std::vector<Utime>> sendTimes(const ReplayOptions& o,
                                            const std::map<int, RobotLog>& logs,
                                            const LinkTiming& link, const Span& span) {
  const Utime shortest = static_cast<Utime>(1e6 / o.max_send_rate_hz) - 5'000;
  std::map<int, std::vector<Utime>> sends;
  for (const auto& [id, r] : logs) {
    std::vector<Utime>& out = sends[id];
    const Utime phase = link.phase.at(id);
    Utime last = span.start + phase - link.send_period;
    std::size_t next_ball = 0;
    bool was_valid = false;
    for (Utime t = span.start + phase; t <= span.end; t += 5'000) {
      while (next_ball < r.balls.size() && r.balls[next_ball].received <= t) {
        const Timed& b = r.balls[next_ball++];
        const bool news = b.ball.valid || was_valid;
        was_valid = b.ball.valid;
        if (o.max_send_rate_hz > o.send_rate_hz && news && b.received - last >= shortest) {
          last = b.received;
          out.push_back(last);
        }
      }
      if (t - last >= link.send_period) {
        last = t;
        out.push_back(last);
      }
    }
  }
  return sends;
}

// The team ball's score over every robot's pictures.
struct TeamTally {
  Score team;
  std::size_t used_total = 0, rejected_total = 0, valid_pictures = 0, pictures = 0;
  // Every picture as fieldline-eval reads TEAM_STATE (its team-ball line scores them).
  std::vector<eval::TeamSample> samples;
  // --budget: every valid scored picture.
  std::vector<eval::BudgetPicture> budget;
};

// Replays one observer's team link: its picture's reports at `now`.
class ObserverReplay {
 public:
  ObserverReplay(const ReplayOptions& o, const std::map<int, RobotLog>& logs,
                 const LinkTiming& link, const std::map<int, std::vector<Utime>>& sends,
                 int observer)
      : o_(o),
        logs_(logs),
        link_(link),
        sends_(sends),
        observer_(observer),
        tp_(observer, o.picture) {}

  teamcomm::TeamPicture& picture() { return tp_; }

  // The picture at the tick, or (--publish-on-ball) at the first own BALL_STATE after it.
  Utime pictureTime(Utime tick) const {
    if (!o_.publish_on_ball) return tick;
    const RobotLog& own_log = logs_.at(observer_);
    const auto next = std::lower_bound(own_log.balls.begin(), own_log.balls.end(), tick,
                                       [](const Timed& e, Utime x) { return e.received < x; });
    if (next != own_log.balls.end() && next->received - tick < link_.publish_period)
      return next->received;
    return tick;
  }

  void setReports(Utime now) {
    for (const auto& [id, r] : logs_) {
      teamcomm::Report report;
      if (id == observer_) {
        const Timed* pose = newestAt(r.robots, now);
        if (!pose || now - pose->received > o_.picture.present_timeout_us) {
          tp_.clear(id);
          continue;
        }
        report.robot = pose->robot;
        report.received_utime = pose->received;
        if (const Timed* ball = newestAt(r.balls, now)) report.ball = ball->ball;
      } else if (!teammateReport(id, r, now, report)) {
        continue;
      }
      tp_.setReport(id, report);
    }
  }

 private:
  // The teammate's newest packet that has arrived: sent on its send clock (false: none yet).
  bool teammateReport(int id, const RobotLog& r, Utime now, teamcomm::Report& report) const {
    const std::vector<Utime>& sent_at = sends_.at(id);
    const auto after = std::upper_bound(sent_at.begin(), sent_at.end(), now - link_.delay);
    if (after == sent_at.begin()) return false;
    const Utime sent = *std::prev(after);
    const Timed* pose = newestAt(r.robots, sent);
    if (pose && sent - pose->received <= link_.fresh) {
      report.robot = pose->robot;
    } else if (const teamcomm::Report* previous = tp_.report(id)) {
      report.robot = previous->robot;  // heard, without a fresh pose: the last one ages
    } else {
      return false;
    }
    report.received_utime = sent + link_.delay;
    const Timed* ball = newestAt(r.balls, sent);
    if (ball && ball->ball.valid && sent - ball->received <= link_.fresh) report.ball = ball->ball;
    return true;
  }

  const ReplayOptions& o_;
  const std::map<int, RobotLog>& logs_;
  const LinkTiming& link_;
  const std::map<int, std::vector<Utime>>& sends_;
  int observer_;
  teamcomm::TeamPicture tp_;
};

// One scored team picture for --pictures: the team ball and each robot's ball against the truth.
void writePictureRow(std::FILE* pictures_csv, const std::vector<eval::TruthSample>& truth,
                     int observer, Utime now, Utime start, const Eigen::Vector2d& t,
                     const teamcomm::TeamBallResult& result, const perception::TeamState& state) {
  // The ball's speed needs the truth 50 ms later: an empty cell at the end of the recording.
  Eigen::Vector2d later;
  std::string speed;
  if (ballAt(truth, now + 50'000, later)) speed = fmt::format("{:.3f}", (later - t).norm() / 0.05);
  std::fprintf(pictures_csv, "%d,%.3f,%s,%.4f,%.4f", observer,
               static_cast<double>(now - start) / 1e6, speed.c_str(), (result.position - t).norm(),
               std::sqrt(0.5 * result.covariance.trace()));
  for (const perception::TeammateState& m : state.robots) {
    if (m.ball_valid) {
      std::fprintf(pictures_csv, ",%.4f,%.3f", std::hypot(m.ball_x - t.x(), m.ball_y - t.y()),
                   std::hypot(m.ball_x - m.x, m.ball_y - m.y));
    } else {
      std::fprintf(pictures_csv, ",,");
    }
  }
  // The team ball's NEES and its reporters (digits of their ids), to find the samples out of band.
  const Eigen::Vector2d e = result.position - t;
  std::string used;
  for (const int id : result.used)
    used += std::to_string(id);
  std::fprintf(pictures_csv, ",%.4f,%s\n", e.dot(result.covariance.inverse() * e), used.c_str());
}

// Every reporter's ball in a scored team picture for --reporters: how much of its error at the
// picture's time its own estimate had at its stamp, and how much came with the time since.
void writeReporterRows(std::FILE* reporters_csv, const std::vector<eval::TruthSample>& truth,
                       int observer, Utime now, Utime start, const Eigen::Vector2d& t,
                       const teamcomm::TeamBallResult& result, const perception::TeamState& state,
                       const teamcomm::TeamPicture& picture) {
  for (std::size_t i = 0; i < state.robots.size(); ++i) {
    const perception::TeammateState& m = state.robots[i];
    const int id = static_cast<int>(i) + 1;
    const teamcomm::Report* report = picture.report(id);
    Eigen::Vector2d at_stamp;
    if (!m.ball_valid || !report || !ballAt(truth, report->ball.utime, at_stamp)) continue;
    const perception::BallEstimate& b = report->ball;
    const Eigen::Vector2d held(b.x, b.y);
    const bool used = std::find(result.used.begin(), result.used.end(), id) != result.used.end();
    std::fprintf(reporters_csv, "%d,%.3f,%d,%d,%.1f,%.1f,%.3f,%.4f,%.4f,%.4f,%.4f,%.3f\n", observer,
                 static_cast<double>(now - start) / 1e6, id, used ? 1 : 0,
                 static_cast<double>(now - b.utime) / 1e3,
                 static_cast<double>(now - b.last_seen_utime) / 1e3, std::hypot(b.vx, b.vy),
                 (held - at_stamp).norm(), std::hypot(m.ball_x - t.x(), m.ball_y - t.y()),
                 (held - t).norm(), std::sqrt(0.5 * b.covariance.trace()),
                 std::hypot(m.ball_x - m.x, m.ball_y - m.y));
  }
}

// A valid scored picture for --budget: the true ball's speed, the used reporters' balls.
eval::BudgetPicture budgetPicture(const std::vector<eval::TruthSample>& truth, Utime now,
                                  const Eigen::Vector2d& t, const teamcomm::TeamBallResult& result,
                                  const perception::TeamState& state,
                                  const teamcomm::TeamPicture& picture) {
  eval::BudgetPicture p{now, (result.position - t).norm(), 0.0, {}};
  Eigen::Vector2d later, at_stamp;
  if (ballAt(truth, now + 50'000, later)) p.true_speed_mps = (later - t).norm() / 0.05;
  for (const int id : result.used) {
    const teamcomm::Report* report = picture.report(id);
    if (!report || id < 1 || static_cast<std::size_t>(id) > state.robots.size()) continue;
    const perception::TeammateState& m = state.robots[static_cast<std::size_t>(id - 1)];
    const perception::BallEstimate& b = report->ball;
    // Without the truth at its stamp (a gap in SIM_WORLD): its error there unknown.
    const double at_stamp_error = ballAt(truth, b.utime, at_stamp)
                                      ? (Eigen::Vector2d(b.x, b.y) - at_stamp).norm()
                                      : std::numeric_limits<double>::quiet_NaN();
    p.used.push_back(
        {std::hypot(m.ball_x - m.x, m.ball_y - m.y), std::hypot(b.vx, b.vy), at_stamp_error});
  }
  return p;
}

// Each robot's team picture at the publish rate, scored against the truth.
TeamTally replayTeamBall(const ReplayOptions& o, const std::map<int, RobotLog>& logs,
                         const std::vector<eval::TruthSample>& truth, const Span& span,
                         std::FILE* pictures_csv, std::FILE* reporters_csv, std::FILE* others_csv,
                         const team_bench::SightingRows& bodies) {
  const LinkTiming link = linkTiming(o, logs);
  const std::map<int, std::vector<Utime>> sends = sendTimes(o, logs, link, span);
  TeamTally tally;
  for (const auto& [observer, own_log] : logs) {
    ObserverReplay replay(o, logs, link, sends, observer);
    for (Utime tick = span.start + link.phase.at(observer) % link.publish_period; tick <= span.end;
         tick += link.publish_period) {
      const Utime now = replay.pictureTime(tick);
      replay.setReports(now);
      teamcomm::TeamBallResult result;
      const perception::TeamState state = replay.picture().picture(now, &result);
      eval::TeamSample sample;
      sample.robot = observer;
      sample.utime = now;
      sample.team_ball_valid = result.valid;
      sample.team_ball_x = result.position.x();
      sample.team_ball_y = result.position.y();
      sample.team_ball_covariance = result.covariance;
      for (std::size_t i = 0; i < sample.sees.size(); ++i) {
        const perception::TeammateState& m = state.robots[i];
        sample.sees[i] = m.ball_valid && m.ball_age_us <= eval::TeamBallOptions{}.seen_window_us;
      }
      tally.samples.push_back(sample);
      if (now < span.scored_from) continue;
      ++tally.pictures;
      if (!result.valid) continue;
      ++tally.valid_pictures;
      Eigen::Vector2d t;
      if (!ballAt(truth, now, t)) continue;
      tally.team.add(result.position - t, result.covariance);
      tally.used_total += result.used.size();
      tally.rejected_total += result.rejected.size();
      if (o.budget)
        tally.budget.push_back(budgetPicture(truth, now, t, result, state, replay.picture()));
      if (pictures_csv)
        writePictureRow(pictures_csv, truth, observer, now, span.start, t, result, state);
      if (reporters_csv)
        writeReporterRows(reporters_csv, truth, observer, now, span.start, t, result, state,
                          replay.picture());
      if (others_csv)
        team_bench::writeOtherRows(others_csv, truth, logs, observer, now, span.start, t, result,
                                   state, replay.picture(), o.picture, bodies);
    }
  }
  return tally;
}

void printScores(std::map<int, Score>& own, const TeamTally& tally) {
  int best = -1;
  for (const auto& [id, s] : own) {
    if (s.n >= 30 && (best < 0 || s.mean() < own[best].mean())) best = id;
  }
  for (const auto& [id, s] : own) {
    std::printf("own ball robot %d: mean %.4f m (%zu), NEES in band %.3f, mean NEES %.2f, %s\n", id,
                s.mean(), s.n, s.inBand(), s.neesMean(), s.neesSpread().c_str());
  }
  const Score& team = tally.team;
  std::printf(
      "team_ball_mean_m=%.4f best_own_ball_mean_m=%.4f (robot %d) team_ball_nees_in_band=%.3f "
      "mean NEES %.2f (%s) valid %.3f used %.2f rejected %.2f per picture\n",
      team.mean(), best >= 0 ? own[best].mean() : -1.0, best, team.inBand(), team.neesMean(),
      team.neesSpread().c_str(),
      tally.pictures
          ? static_cast<double>(tally.valid_pictures) / static_cast<double>(tally.pictures)
          : 0.0,
      team.n ? static_cast<double>(tally.used_total) / static_cast<double>(team.n) : 0.0,
      team.n ? static_cast<double>(tally.rejected_total) / static_cast<double>(team.n) : 0.0);
}

// An output file, or nullptr when its path is empty; with its CSV header written.
std::FILE* openCsv(const std::string& path, const std::string& header) {
  std::FILE* f = path.empty() ? nullptr : std::fopen(path.c_str(), "w");
  if (f) std::fputs(header.c_str(), f);
  return f;
}

std::string picturesHeader() {
  std::string header = "observer,t,ball_speed,team_err,team_sigma";
  for (int i = 1; i <= perception::kTeamSize; ++i)
    header += fmt::format(",err{},range{}", i, i);
  return header + ",nees,used\n";
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Recomputes the team ball of a recorded match (bench/fusion/record_match.sh) with teamcomm's "
      "TeamPicture and scores it, and every robot's own ball, against the truth (mean error and "
      "NEES in the 95 % band)."};
  ReplayOptions o;
  o.addTo(app);
  FIELDLINE_CLI_PARSE(app, argc, argv);
  // A missing or unreadable recording is a clear error, not an abort.
  try {
    o.picture.max_prediction_us = static_cast<Utime>(o.max_prediction_s * 1e6);
    o.picture.superseded_after_us = static_cast<Utime>(o.superseded_after_s * 1e6);
    team_bench::SightingRows sightings(o.sightings_path);
    const std::vector<eval::TruthSample> truth = readTruth(o.dir, sightings);
    if (truth.empty()) {
      std::fprintf(stderr, "no SIM_WORLD in %s/sim.lcm\n", o.dir.c_str());
      return 1;
    }
    const std::map<int, RobotLog> logs =
        readRobotLogs(o.dir, truth, sightings.open() ? &sightings : nullptr);
    if (logs.empty()) {
      std::fprintf(stderr, "no robotN.lcm in %s\n", o.dir.c_str());
      return 1;
    }
    const Span span = recordingSpan(logs, truth, o.settle_s);
    std::FILE* csv =
        openCsv(o.csv_path,
                "robot,t,err,err_along,err_across,range,ball_speed,robot_speed,sigma,since_seen,"
                "pose_err,heading_err_deg,robot_sigma,heading_sigma_deg,status\n");
    std::map<int, Score> own = scoreOwnBalls(logs, truth, span, csv);
    if (csv) std::fclose(csv);
    std::FILE* pictures_csv = openCsv(o.pictures_path, picturesHeader());
    std::FILE* reporters_csv =
        openCsv(o.reporters_path,
                "observer,t,robot,used,age_ms,since_seen_ms,speed_est,err_at_stamp,err_predicted,"
                "err_held,sigma,range\n");
    std::FILE* others_csv = openCsv(o.others_path, team_bench::otherRowsHeader());
    const TeamTally tally =
        replayTeamBall(o, logs, truth, span, pictures_csv, reporters_csv, others_csv, sightings);
    if (others_csv) std::fclose(others_csv);
    sightings.close();
    if (pictures_csv) std::fclose(pictures_csv);
    if (reporters_csv) std::fclose(reporters_csv);
    printScores(own, tally);
    // The same pictures as fieldline-eval scores its TEAM_STATEs (its settle, put-back rules).
    std::vector<eval::BallSample> balls;
    for (const auto& [id, r] : logs) {
      for (const Timed& b : r.balls)
        balls.push_back({id, b.ball.utime, b.ball.valid, b.ball.x, b.ball.y, b.ball.covariance});
    }
    std::printf("fieldline-eval: %s\n",
                eval::teamBallLine(eval::evaluateTeamBall(truth, balls, tally.samples)).c_str());
    if (o.budget)
      std::fputs(eval::budgetTable(eval::teamBallBudget(tally.budget, truth)).c_str(), stdout);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fieldline-team-ball-replay: %s\n", e.what());
    return 1;
  }
}
