#include "tools/eval/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <numbers>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <Eigen/LU>

#include "common/geometry/geometry.hpp"

namespace fieldline::eval {
namespace {

// One colour per robot number (1..6) in the plots.
constexpr const char* kPlotColours[] = {"#e74c3c", "#3498db", "#9b59b6",
                                        "#1abc9c", "#e67e22", "#7f8c8d"};

// Faster than any kick (the scenarios kick at up to 5 m/s, fusion accepts paths up to 12 m/s):
// a jump of the ball between two truth samples is a put-back, m/s.
constexpr double kMaxBallSpeedMps = 20.0;

// Chi-square with 3 degrees of freedom: the central 95 % of single-sample NEES values.
constexpr double kNeesLow = 0.2158;
constexpr double kNeesHigh = 9.3484;

double mean(const std::vector<double>& v) {
  if (v.empty()) return 0.0;
  double s = 0;
  for (double x : v)
    s += x;
  return s / static_cast<double>(v.size());
}

}  // namespace

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(pos);
  const double w = pos - static_cast<double>(i);
  return i + 1 < v.size() ? v[i] * (1 - w) + v[i + 1] * w : v[i];
}

bool truthAt(const std::vector<TruthSample>& truth, Utime t, int robot, TruthRobot& out,
             double* ball_x, double* ball_y) {
  if (truth.empty() || t < truth.front().utime || t > truth.back().utime) return false;
  auto it = std::lower_bound(truth.begin(), truth.end(), t,
                             [](const TruthSample& s, Utime v) { return s.utime < v; });
  const TruthSample& b = *it;
  const TruthSample& a = it == truth.begin() ? b : *std::prev(it);
  const auto ra = a.robots.find(robot);
  const auto rb = b.robots.find(robot);
  if (ra == a.robots.end() || rb == b.robots.end()) return false;
  // A gap in the truth (lost SIM_WORLD messages) longer than 50 ms is not interpolated.
  if (b.utime - a.utime > 50'000) return false;
  const double w = b.utime == a.utime
                       ? 0.0
                       : static_cast<double>(t - a.utime) / static_cast<double>(b.utime - a.utime);
  const TruthRobot& p = ra->second;
  const TruthRobot& q = rb->second;
  // Across a kidnap the truth jumps: take the nearer sample.
  if (p.kidnaps != q.kidnaps) {
    out = w < 0.5 ? p : q;
  } else {
    out.x = p.x + (q.x - p.x) * w;
    out.y = p.y + (q.y - p.y) * w;
    out.phi = geometry::normalizeAngle(p.phi + geometry::angleDiff(q.phi, p.phi) * w);
    out.kidnaps = q.kidnaps;
  }
  // A put-back (the ball faster than any kick between the two samples) is not interpolated: the
  // ball is where the earlier sample has it until the later one shows it elsewhere. Interpolated,
  // an estimate stamped just before the later sample was scored against a point metres from
  // either place (a live match: one team ball 5.4 m off, 14 of a robot's 17 cm).
  const double wb = isPutBack(a, b) ? (t < b.utime ? 0.0 : 1.0) : w;
  if (ball_x) *ball_x = a.ball_x + (b.ball_x - a.ball_x) * wb;
  if (ball_y) *ball_y = a.ball_y + (b.ball_y - a.ball_y) * wb;
  return true;
}

bool isPutBack(const TruthSample& a, const TruthSample& b) {
  const double seconds = static_cast<double>(b.utime - a.utime) * 1e-6;
  return std::hypot(b.ball_x - a.ball_x, b.ball_y - a.ball_y) > kMaxBallSpeedMps * seconds;
}

std::vector<Utime> putBackTimes(const std::vector<TruthSample>& truth) {
  std::vector<Utime> times;
  for (std::size_t i = 1; i < truth.size(); ++i) {
    if (isPutBack(truth[i - 1], truth[i])) times.push_back(truth[i].utime);
  }
  return times;
}

bool justAfterPutBack(const std::vector<Utime>& put_backs, Utime t, Utime blind_us) {
  return std::any_of(put_backs.begin(), put_backs.end(),
                     [&](Utime p) { return t >= p && t - p < blind_us; });
}

namespace {

// Per robot: scoring starts settle_s after its first estimate, or at its first TRACKING if that
// is later (start-up is measured separately: tracking_after_s); never without a TRACKING.
std::map<int, Utime> scoringStarts(const std::vector<StateSample>& states,
                                   const EvalOptions& options) {
  std::map<int, Utime> score_from;
  for (const StateSample& st : states)
    score_from.try_emplace(st.robot, st.utime + static_cast<Utime>(options.settle_s * 1e6));
  std::map<int, bool> seen_tracking;
  for (const StateSample& st : states) {
    if (st.status != 2 || seen_tracking[st.robot]) continue;
    seen_tracking[st.robot] = true;
    score_from[st.robot] = std::max(score_from[st.robot], st.utime);
  }
  for (auto& [r, t] : score_from)
    if (!seen_tracking[r]) t = std::numeric_limits<Utime>::max();
  return score_from;
}

// A state with its truth: the errors and the latency (kidnap and NEES figures come later).
Matched matchedWith(const StateSample& st, const TruthRobot& tr, Utime t0) {
  Matched m;
  m.robot = st.robot;
  m.t = static_cast<double>(st.utime - t0) * 1e-6;
  m.x = st.x;
  m.y = st.y;
  m.phi = st.phi;
  m.true_x = tr.x;
  m.true_y = tr.y;
  m.true_phi = tr.phi;
  m.status = st.status;
  m.twin_ambiguous = st.twin_ambiguous;
  m.pos_error = std::hypot(st.x - tr.x, st.y - tr.y);
  m.heading_error = std::abs(geometry::angleDiff(st.phi, tr.phi));
  m.latency_ms = static_cast<double>(st.published - st.utime) * 1e-3;
  return m;
}

// Every state (sorted by robot, then time) matched with the truth: kidnaps and their recovery,
// wrong-half commits, the position, heading, NEES and latency figures.
void matchStates(const std::vector<TruthSample>& truth, const std::vector<StateSample>& states,
                 Utime t0, const EvalOptions& options, Summary& s) {
  std::vector<double> pos, heading, latency;
  std::map<int, std::vector<double>> pos_by_robot;
  std::size_t nees_in = 0, nees_n = 0;
  std::map<int, Utime> score_from = scoringStarts(states, options);
  int current_robot = -1;
  int last_kidnaps = 0;
  bool recovering = false;
  Utime kidnap_time = 0;
  bool wrong = false;
  for (const StateSample& st : states) {
    TruthRobot tr;
    if (!truthAt(truth, st.utime, st.robot, tr)) continue;
    if (st.robot != current_robot) {
      current_robot = st.robot;
      last_kidnaps = tr.kidnaps;
      recovering = false;
      wrong = false;
    }
    Matched m = matchedWith(st, tr, t0);
    latency.push_back(m.latency_ms);

    if (tr.kidnaps != last_kidnaps) {
      last_kidnaps = tr.kidnaps;
      ++s.kidnaps;
      if (recovering) ++s.unrecovered;
      recovering = true;
      kidnap_time = st.utime;
    }
    const bool tracking = st.status == 2;
    if (recovering && tracking && m.pos_error <= options.recovered_m) {
      recovering = false;
      s.recoveries_s.push_back(static_cast<double>(st.utime - kidnap_time) * 1e-6);
    }
    m.recovering = recovering;

    // Committed on the symmetric twin: near the mirrored truth, far from the truth.
    const bool on_twin =
        tracking && std::hypot(st.x + tr.x, st.y + tr.y) < 0.5 && m.pos_error > 1.0;
    if (on_twin && !wrong) ++s.wrong_half;
    wrong = on_twin;

    const Eigen::Vector3d e(st.x - tr.x, st.y - tr.y, geometry::angleDiff(st.phi, tr.phi));
    const Eigen::Matrix3d c = st.covariance;
    m.nees = c.determinant() > 0 ? e.dot(c.inverse() * e) : 1e9;
    if (st.utime >= score_from[st.robot] && !recovering) {
      pos.push_back(m.pos_error);
      heading.push_back(m.heading_error * 180.0 / std::numbers::pi);
      pos_by_robot[st.robot].push_back(m.pos_error);
      ++nees_n;
      if (m.nees >= kNeesLow && m.nees <= kNeesHigh) ++nees_in;
    }
    s.matched.push_back(m);
  }
  if (recovering) ++s.unrecovered;
  s.scored = pos.size();
  s.pos_mean_m = mean(pos);
  s.pos_p99_m = percentile(pos, 0.99);
  s.pos_max_m = pos.empty() ? 0.0 : *std::max_element(pos.begin(), pos.end());
  s.heading_mean_deg = mean(heading);
  s.recovery_median_s = percentile(s.recoveries_s, 0.5);
  s.recovery_max_s = s.recoveries_s.empty()
                         ? 0.0
                         : *std::max_element(s.recoveries_s.begin(), s.recoveries_s.end());
  s.nees_in_band = nees_n ? static_cast<double>(nees_in) / static_cast<double>(nees_n) : 0.0;
  s.latency_p50_ms = percentile(latency, 0.5);
  s.latency_p95_ms = percentile(latency, 0.95);
  for (const auto& [r, v] : pos_by_robot)
    s.pos_mean_by_robot[r] = mean(v);
}

// Per robot: the median interval between consecutive BALL_STATE stamps, ms.
// Per robot: the median and the longest interval between its BALL_STATE stamps, ms.
void ballStateIntervals(const std::vector<BallSample>& balls, Summary& s) {
  std::map<int, std::vector<Utime>> stamps;
  for (const BallSample& b : balls)
    stamps[b.robot].push_back(b.utime);
  for (auto& [r, t] : stamps) {
    if (t.size() < 2) continue;
    std::sort(t.begin(), t.end());
    std::vector<Utime> gaps;
    for (std::size_t i = 1; i < t.size(); ++i)
      gaps.push_back(t[i] - t[i - 1]);
    s.ball_state_interval_max_ms[r] =
        static_cast<double>(*std::max_element(gaps.begin(), gaps.end())) * 1e-3;
    std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2),
                     gaps.end());
    s.ball_state_interval_p50_ms[r] = static_cast<double>(gaps[gaps.size() / 2]) * 1e-3;
  }
}

// Start-up and rates per robot: tracking_after_s, tracking_after_vision_s, ROBOT_STATE and
// BALL_STATE rates.
void robotRates(const std::vector<StateSample>& states, const std::vector<BallSample>& balls,
                const std::map<int, Utime>& first_lines, Summary& s) {
  std::map<int, std::pair<Utime, Utime>> span;
  std::map<int, std::size_t> count;
  for (const StateSample& st : states) {
    auto [it, inserted] = span.try_emplace(st.robot, st.utime, st.utime);
    it->second.first = std::min(it->second.first, st.utime);
    it->second.second = std::max(it->second.second, st.utime);
    ++count[st.robot];
    if (!s.tracking_after_s.count(st.robot)) s.tracking_after_s[st.robot] = -1.0;
    if (st.status == 2 && s.tracking_after_s[st.robot] < 0)
      s.tracking_after_s[st.robot] = static_cast<double>(st.utime - it->second.first) * 1e-6;
  }
  for (const auto& [r, first] : first_lines) {
    double after = -1.0;
    for (const StateSample& st : states) {
      if (st.robot == r && st.status == 2) {
        after = static_cast<double>(st.utime - first) * 1e-6;
        break;
      }
    }
    s.tracking_after_vision_s[r] = after;
  }
  for (const auto& [r, sp] : span) {
    const double seconds = static_cast<double>(sp.second - sp.first) * 1e-6;
    s.robot_state_hz[r] = seconds > 0 ? static_cast<double>(count[r] - 1) / seconds : 0.0;
  }
  std::map<int, std::pair<Utime, Utime>> ball_span;
  std::map<int, std::size_t> ball_count;
  for (const BallSample& b : balls) {
    auto [it, inserted] = ball_span.try_emplace(b.robot, b.utime, b.utime);
    it->second.first = std::min(it->second.first, b.utime);
    it->second.second = std::max(it->second.second, b.utime);
    ++ball_count[b.robot];
  }
  for (const auto& [r, sp] : ball_span) {
    const double seconds = static_cast<double>(sp.second - sp.first) * 1e-6;
    s.ball_state_hz[r] = seconds > 0 ? static_cast<double>(ball_count[r] - 1) / seconds : 0.0;
  }
  ballStateIntervals(balls, s);
}

// Every valid BALL_STATE after the settle time whose robot is within ball_range_m of the ball.
void scoreBalls(const std::vector<TruthSample>& truth, const std::vector<BallSample>& balls,
                Utime t0, const EvalOptions& options, Summary& s) {
  std::vector<double> ball_errors;
  for (const BallSample& b : balls) {
    if (!b.valid || static_cast<double>(b.utime - t0) * 1e-6 < options.settle_s) continue;
    TruthRobot tr;
    double bx = 0, by = 0;
    if (!truthAt(truth, b.utime, b.robot, tr, &bx, &by)) continue;
    const double range = std::hypot(bx - tr.x, by - tr.y);
    if (range > options.ball_range_m) continue;
    ball_errors.push_back(std::hypot(b.x - bx, b.y - by));
    s.balls.push_back({b.robot, static_cast<double>(b.utime - t0) * 1e-6, b.x, b.y, bx, by,
                       ball_errors.back(), range});
  }
  s.balls_scored = ball_errors.size();
  s.ball_mean_m = mean(ball_errors);
}

}  // namespace

Summary evaluate(const std::vector<TruthSample>& truth, std::vector<StateSample> states,
                 std::vector<BallSample> balls, const EvalOptions& options,
                 const std::map<int, Utime>& first_lines) {
  Summary s;
  s.states = states.size();
  if (states.empty()) return s;
  std::sort(states.begin(), states.end(), [](const StateSample& a, const StateSample& b) {
    return a.robot != b.robot ? a.robot < b.robot : a.utime < b.utime;
  });
  Utime t0 = states.front().utime;
  for (const auto& st : states)
    t0 = std::min(t0, st.utime);
  matchStates(truth, states, t0, options, s);
  robotRates(states, balls, first_lines, s);
  scoreBalls(truth, balls, t0, options, s);
  return s;
}

std::string summaryLine(const Summary& s) {
  return fmt::format(
      "pos_mean_m={:.4f} pos_p99_m={:.4f} pos_max_m={:.4f} heading_mean_deg={:.3f} "
      "recovery_median_s={:.3f} recovery_max_s={:.3f} wrong_half={} nees_in_band={:.3f} "
      "ball_mean_m={:.4f}",
      s.pos_mean_m, s.pos_p99_m, s.pos_max_m, s.heading_mean_deg, s.recovery_median_s,
      s.recovery_max_s, s.wrong_half, s.nees_in_band, s.ball_mean_m);
}

std::string summaryJson(const Summary& s, const std::string& source) {
  std::ostringstream o;
  o << "{\n";
  o << fmt::format("  \"source\": \"{}\",\n", source);
  o << fmt::format("  \"states\": {}, \"scored\": {}, \"balls_scored\": {},\n", s.states, s.scored,
                   s.balls_scored);
  o << fmt::format(
      "  \"pos_mean_m\": {:.5f}, \"pos_p99_m\": {:.5f}, \"pos_max_m\": {:.5f}, "
      "\"heading_mean_deg\": {:.4f},\n",
      s.pos_mean_m, s.pos_p99_m, s.pos_max_m, s.heading_mean_deg);
  o << fmt::format(
      "  \"kidnaps\": {}, \"unrecovered\": {}, \"recovery_median_s\": {:.3f}, "
      "\"recovery_max_s\": {:.3f},\n",
      s.kidnaps, s.unrecovered, s.recovery_median_s, s.recovery_max_s);
  o << fmt::format("  \"wrong_half\": {}, \"nees_in_band\": {:.4f}, \"ball_mean_m\": {:.5f},\n",
                   s.wrong_half, s.nees_in_band, s.ball_mean_m);
  o << fmt::format("  \"latency_p50_ms\": {:.2f}, \"latency_p95_ms\": {:.2f},\n", s.latency_p50_ms,
                   s.latency_p95_ms);
  o << "  \"pos_mean_by_robot\": {";
  bool first = true;
  for (const auto& [r, v] : s.pos_mean_by_robot) {
    o << fmt::format("{}\"{}\": {:.5f}", first ? "" : ", ", r, v);
    first = false;
  }
  o << "},\n";
  const auto perRobot = [&](const char* name, const std::map<int, double>& values, bool last) {
    o << "  \"" << name << "\": {";
    bool f = true;
    for (const auto& [r, v] : values) {
      o << fmt::format("{}\"{}\": {:.3f}", f ? "" : ", ", r, v);
      f = false;
    }
    o << (last ? "}\n" : "},\n");
  };
  perRobot("tracking_after_s", s.tracking_after_s, false);
  perRobot("tracking_after_vision_s", s.tracking_after_vision_s, false);
  perRobot("robot_state_hz", s.robot_state_hz, false);
  perRobot("ball_state_hz", s.ball_state_hz, false);
  perRobot("ball_state_interval_p50_ms", s.ball_state_interval_p50_ms, false);
  perRobot("ball_state_interval_max_ms", s.ball_state_interval_max_ms, true);
  o << "}\n";
  return o.str();
}

std::string plotScript(const Summary& s, const std::string& dir, double half_length,
                       double half_width) {
  std::set<int> robots;
  for (const Matched& m : s.matched)
    robots.insert(m.robot);
  std::string gp;
  // The samples as gnuplot data blocks, one per robot: t, error, heading error, latency, the
  // estimate and the truth.
  for (const int r : robots) {
    gp += fmt::format("$R{} << EOD\n", r);
    const Matched* previous = nullptr;
    for (const Matched& m : s.matched) {
      if (m.robot != r) continue;
      // A jump of the estimate (a relocalization) breaks its line instead of drawing across.
      if (previous && std::hypot(m.x - previous->x, m.y - previous->y) > 0.5) gp += "\n";
      previous = &m;
      gp += fmt::format("{:.3f} {:.4f} {:.3f} {:.2f} {:.4f} {:.4f} {:.4f} {:.4f}\n", m.t,
                        m.pos_error, m.heading_error * 180.0 / std::numbers::pi, m.latency_ms, m.x,
                        m.y, m.true_x, m.true_y);
    }
    gp += "EOD\n";
  }
  const auto plotEach = [&](const std::string& columns, const std::string& style) {
    std::string list;
    for (const int r : robots) {
      list += fmt::format("{}$R{} using {} with {} lw 1.2 lc rgb '{}' title 'robot {}'",
                          list.empty() ? "" : ", ", r, columns, style,
                          kPlotColours[static_cast<std::size_t>((r - 1 + 6) % 6)], r);
    }
    return list.empty() ? std::string("NaN notitle") : list;
  };
  gp += "set terminal pngcairo noenhanced size 1100,700 font 'sans,10'\n";
  gp += "set grid\nset key outside right top\n";
  // Errors over time: position (m) and heading (deg).
  gp += fmt::format("set output '{}/errors.png'\n", dir);
  gp += "set multiplot layout 2,1 title 'Localization error against the simulator''s truth'\n";
  // Logarithmic: centimetres while tracking and metres while lost in one picture.
  gp += "set logscale y\n";
  gp += "set xlabel 'time since the first estimate [s]'\n";
  gp += "set ylabel 'position error [m] (log scale)'\n";
  gp += "plot " + plotEach("1:($2 > 0 ? $2 : 1/0)", "lines") + "\n";
  gp += "set ylabel 'heading error [deg] (log scale)'\n";
  gp += "plot " + plotEach("1:($3 > 0 ? $3 : 1/0)", "lines") + "\n";
  gp += "unset multiplot\nunset logscale y\n";
  // Latency over time.
  gp += fmt::format("set output '{}/latency.png'\n", dir);
  gp += "set title 'ROBOT_STATE latency (utime_published - utime)'\n";
  gp += "set xlabel 'time since the first estimate [s]'\nset ylabel 'latency [ms]'\n";
  gp += "plot " + plotEach("1:4", "points pt 7 ps 0.3") + "\n";
  // Trajectories on the field: truth dashed grey, estimates coloured.
  gp += fmt::format("set output '{}/trajectories.png'\n", dir);
  gp += "set title 'Trajectories in the field frame (wide grey: truth, under the estimates)'\n";
  gp += "set size ratio -1\nset xlabel 'x [m]'\nset ylabel 'y [m]'\n";
  gp += fmt::format("set xrange [{:.2f}:{:.2f}]\nset yrange [{:.2f}:{:.2f}]\n", -half_length,
                    half_length, -half_width, half_width);
  std::string truth;
  for (const int r : robots)
    truth += fmt::format("$R{} using 7:8 with lines lw 5 lc rgb '#cccccc' notitle, ", r);
  gp += "plot " + truth + plotEach("5:6", "lines") + "\n";
  gp += "unset output\n";
  return gp;
}

bool writePlots(const Summary& s, const std::string& dir, double half_length, double half_width) {
  const std::string script = dir + "/plots.gp";
  std::ofstream(script) << plotScript(s, dir, half_length, half_width);
  // gnuplot (Debian's gnuplot-nox, scripts/setup) draws them; without it the script stays.
  const std::string command = "gnuplot '" + script + "' 2> '" + dir + "/plots.log'";
  const int rc = std::system(command.c_str());
  return rc == 0;
}

}  // namespace fieldline::eval
