#include "tools/eval/faults.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

namespace fieldline::eval {
namespace {

constexpr int kTracking = 2;

const std::set<std::string>& knownProcesses() {
  static const std::set<std::string> names{"camera",   "region_tracking", "feature_recognition",
                                           "fusion",   "motor_bridge",    "pilot",
                                           "teamcomm", "world_sim",       "viewer"};
  return names;
}

bool simulatorProcess(const std::string& name) {
  return name == "world_sim" || name == "viewer";
}

double parseSeconds(const std::string& text, const std::string& what, const std::string& spec) {
  double v = 0.0;
  const char* end = text.data() + text.size();
  const auto r = std::from_chars(text.data(), end, v);
  if (text.empty() || r.ec != std::errc{} || r.ptr != end || !std::isfinite(v) || v < 0.0)
    throw std::invalid_argument(
        fmt::format("fault '{}': {} '{}' is not a number of seconds >= 0", spec, what, text));
  return v;
}

int parseRobot(const std::string& text, const std::string& spec) {
  int v = 0;
  const char* end = text.data() + text.size();
  const auto r = std::from_chars(text.data(), end, v);
  if (text.empty() || r.ec != std::errc{} || r.ptr != end || v < 1 || v > 6)
    throw std::invalid_argument(
        fmt::format("fault '{}': robot '{}' is not a robot number 1..6", spec, text));
  return v;
}

// Seconds from `from` to the start of the robot's first stretch (at or after `from`) of
// hold_s of TRACKING samples within recovered_m, none further apart than max_gap_s; -1: none.
double recoveryAfter(const std::vector<const Matched*>& samples, double from,
                     const RobustnessOptions& o) {
  double stretch_start = -1.0;
  double last_t = -1.0;
  for (const Matched* m : samples) {
    if (m->t < from) continue;
    const bool good = m->status == kTracking && m->pos_error <= o.recovered_m;
    if (!good || (stretch_start >= 0.0 && m->t - last_t > o.max_gap_s)) stretch_start = -1.0;
    if (good && stretch_start < 0.0) stretch_start = m->t;
    last_t = m->t;
    if (stretch_start >= 0.0 && m->t - stretch_start >= o.hold_s) return stretch_start - from;
  }
  return -1.0;
}

// clockstep:ROBOT@T+S or @T-S: the step, signed; `when` keeps T.
double parseClockStep(std::string& when, const std::string& spec) {
  const auto sign = when.find_first_of("+-");
  if (sign == std::string::npos)
    throw std::invalid_argument(
        fmt::format("fault '{}': a clock step needs its size, e.g. clockstep:1@20+2 (2 s ahead) or "
                    "clockstep:1@20-2 (2 s behind)",
                    spec));
  const double size = parseSeconds(when.substr(sign + 1), "step", spec);
  if (!(size >= kMinClockStepS && size <= kMaxClockStepS))
    throw std::invalid_argument(fmt::format(
        "fault '{}': a clock step is at least {} s (smaller ones cannot be told from the bus's "
        "latency) and at most {} s either way",
        spec, kMinClockStepS, kMaxClockStepS));
  const double step = when[sign] == '+' ? size : -size;
  when = when.substr(0, sign);
  return step;
}

// Per teammate of the stepped robot: seconds from the step to the first TEAM_STATE holding a
// fresh pose of the stepped robot taken on its new clock; and the packets refused meanwhile.
void scoreTeamLink(FaultResult& f, const std::vector<TeamLinkSample>& team,
                   const RobustnessOptions& o) {
  const int stepped = f.event.spec.robot;
  const auto k = static_cast<std::size_t>(stepped - 1);
  const double new_clock_t = f.event.new_clock_t.value_or(f.event.end_t);
  std::map<int, int> rejected_before;
  std::map<int, int> rejected_until;
  for (const TeamLinkSample& s : team) {
    if (s.robot == stepped || k >= s.present.size()) continue;
    f.heard_again_s.try_emplace(s.robot, -1.0);
    if (s.t < f.event.end_t) {
      rejected_before[s.robot] = s.rejected[k];
      continue;
    }
    double& heard = f.heard_again_s[s.robot];
    if (heard >= 0.0) continue;
    rejected_until[s.robot] = s.rejected[k];
    const double age = s.t - s.pose_t[k];
    if (s.present[k] && s.pose_t[k] >= new_clock_t && age <= o.heard_age_s)
      heard = s.t - f.event.end_t;
  }
  for (const auto& [robot, until] : rejected_until)
    f.packets_refused += until - rejected_before[robot];
}

}  // namespace

FaultSpec parseFault(const std::string& text) {
  FaultSpec f;
  f.text = text;
  const auto colon = text.find(':');
  const auto at = text.find('@');
  if (colon == std::string::npos || at == std::string::npos || at < colon) {
    throw std::invalid_argument(
        fmt::format("fault '{}': expected KIND:TARGET@SECONDS (restart:fusion/2@20, "
                    "kill:camera/1@15, stall:3@20+2, stall:all@25+1.5, clockstep:1@20+2)",
                    text));
  }
  const std::string kind = text.substr(0, colon);
  const std::string target = text.substr(colon + 1, at - colon - 1);
  std::string when = text.substr(at + 1);
  if (kind == "stall") {
    f.kind = FaultSpec::Kind::kStall;
    const auto plus = when.find('+');
    if (plus == std::string::npos)
      throw std::invalid_argument(
          fmt::format("fault '{}': a stall needs its length, e.g. stall:2@20+1.5", text));
    f.duration_s = parseSeconds(when.substr(plus + 1), "length", text);
    if (f.duration_s <= 0.0 || f.duration_s > 60.0)
      throw std::invalid_argument(
          fmt::format("fault '{}': a stall lasts more than 0 and at most 60 s", text));
    when = when.substr(0, plus);
    f.robot = target == "all" ? 0 : parseRobot(target, text);
  } else if (kind == "clockstep") {
    f.kind = FaultSpec::Kind::kClockStep;
    if (target == "all")
      throw std::invalid_argument(fmt::format(
          "fault '{}': a clock step is of one robot's clock (clockstep:1@20+2), not all", text));
    f.robot = parseRobot(target, text);
    f.step_s = parseClockStep(when, text);
  } else if (kind == "restart" || kind == "kill") {
    f.kind = kind == "restart" ? FaultSpec::Kind::kRestart : FaultSpec::Kind::kKill;
    const auto slash = target.find('/');
    f.process = target.substr(0, slash);
    if (!knownProcesses().contains(f.process)) {
      std::string names;
      for (const std::string& n : knownProcesses())
        names += (names.empty() ? "" : ", ") + n;
      throw std::invalid_argument(
          fmt::format("fault '{}': no process '{}' (one of: {})", text, f.process, names));
    }
    if (slash != std::string::npos) {
      if (simulatorProcess(f.process))
        throw std::invalid_argument(
            fmt::format("fault '{}': {} belongs to no robot (drop the /ROBOT)", text, f.process));
      f.robot = parseRobot(target.substr(slash + 1), text);
    }
  } else {
    throw std::invalid_argument(fmt::format(
        "fault '{}': unknown kind '{}' (restart, kill, stall or clockstep)", text, kind));
  }
  f.at_s = parseSeconds(when, "time", text);
  return f;
}

// long: one pass over the samples that scores every fault window and the whole run together.
Robustness evaluateRobustness(const Summary& summary, const std::vector<FaultEvent>& events,
                              const std::vector<int>& robots, const RobustnessOptions& o,
                              const std::vector<TeamLinkSample>& team) {
  Robustness r;
  std::map<int, std::vector<const Matched*>> by_robot;
  for (const Matched& m : summary.matched)
    by_robot[m.robot].push_back(&m);
  for (auto& [robot, v] : by_robot)
    std::stable_sort(v.begin(), v.end(),
                     [](const Matched* a, const Matched* b) { return a->t < b->t; });

  std::vector<double> errors;
  double sum = 0.0;
  for (const Matched& m : summary.matched) {
    if (m.status != kTracking) continue;
    errors.push_back(m.pos_error);
    sum += m.pos_error;
    if (m.pos_error > o.limit_m) ++r.tracking_over_limit;
    if (m.twin_ambiguous) {
      ++r.twin_ambiguous_samples;
    } else {
      r.certain_max_m = std::max(r.certain_max_m, m.pos_error);
      if (m.pos_error > o.limit_m) ++r.certain_over_limit;
    }
    if (m.pos_error > r.tracking_max_m || errors.size() == 1) {
      r.tracking_max_m = m.pos_error;
      r.worst_robot = m.robot;
      r.worst_t = m.t;
    }
  }
  r.tracking_samples = errors.size();
  r.tracking_mean_m = errors.empty() ? 0.0 : sum / static_cast<double>(errors.size());
  r.tracking_p99_m = percentile(errors, 0.99);

  double all_time = 0.0, all_not = 0.0;
  for (const auto& [robot, v] : by_robot) {
    const auto first =
        std::find_if(v.begin(), v.end(), [](const Matched* m) { return m->status == kTracking; });
    if (first == v.end()) {
      r.not_tracking_share_by_robot[robot] = 1.0;
      continue;
    }
    double total = 0.0, not_tracking = 0.0;
    for (auto it = first; std::next(it) != v.end(); ++it) {
      const double dt = (*std::next(it))->t - (*it)->t;
      total += dt;
      const double held = std::min(dt, o.max_gap_s);
      not_tracking += (*it)->status == kTracking ? dt - held : dt;
    }
    r.not_tracking_share_by_robot[robot] = total > 0.0 ? not_tracking / total : 0.0;
    all_time += total;
    all_not += not_tracking;
  }
  r.not_tracking_share = all_time > 0.0 ? all_not / all_time : 0.0;

  for (const FaultEvent& e : events) {
    FaultResult f;
    f.event = e;
    std::vector<int> affected;
    if (e.spec.robot > 0) {
      affected.push_back(e.spec.robot);
    } else {
      affected = robots;
    }
    for (const int robot : affected) {
      const auto it = by_robot.find(robot);
      const double rec = it == by_robot.end() ? -1.0 : recoveryAfter(it->second, e.end_t, o);
      f.recovery_s[robot] = rec;
      if (rec < 0.0 || f.recovery_max_s < 0.0) {
        f.recovery_max_s = -1.0;
      } else {
        f.recovery_max_s = std::max(f.recovery_max_s, rec);
      }
      if (it == by_robot.end()) continue;
      for (const Matched* m : it->second) {
        if (m->t < e.start_t || m->t > e.end_t + o.after_s || m->status != kTracking) continue;
        f.max_tracking_error_m = std::max(f.max_tracking_error_m, m->pos_error);
        if (m->pos_error > o.limit_m) ++f.tracking_over_limit;
        if (m->twin_ambiguous) continue;
        f.certain_max_m = std::max(f.certain_max_m, m->pos_error);
        if (m->pos_error > o.limit_m) ++f.certain_over_limit;
      }
    }
    if (e.spec.kind == FaultSpec::Kind::kClockStep) scoreTeamLink(f, team, o);
    r.faults.push_back(std::move(f));
  }
  return r;
}

std::string robustnessLines(const Robustness& r, const RobustnessOptions& o) {
  std::string out = fmt::format(
      "tracking_max_m={:.4f} (robot {} at {:.2f} s) tracking_over_{}m={} tracking_p99_m={:.4f} "
      "not_tracking_share={:.4f} ({} TRACKING samples; not twin-ambiguous: max {:.4f} m, {} over "
      "{} m; {} twin-ambiguous)",
      r.tracking_max_m, r.worst_robot, r.worst_t, o.limit_m, r.tracking_over_limit,
      r.tracking_p99_m, r.not_tracking_share, r.tracking_samples, r.certain_max_m,
      r.certain_over_limit, o.limit_m, r.twin_ambiguous_samples);
  if (!r.vision_lines_hz.empty()) {
    out += "\nvision_lines_hz:";
    for (const auto& [robot, hz] : r.vision_lines_hz)
      out += fmt::format(" {}={:.1f}", robot, hz);
  }
  for (const FaultResult& f : r.faults) {
    std::string per_robot;
    for (const auto& [robot, s] : f.recovery_s)
      per_robot += fmt::format(" {}={:.2f}", robot, s);
    out += fmt::format(
        "\nfault {} ({:.2f}-{:.2f} s, {} process(es)): recovery_max_s={:.2f} "
        "max_tracking_error_m={:.4f} tracking_over_{}m={} (not twin-ambiguous: {:.4f} m, {}) "
        "recovery_s:{}",
        f.event.spec.text, f.event.start_t, f.event.end_t, f.event.processes, f.recovery_max_s,
        f.max_tracking_error_m, o.limit_m, f.tracking_over_limit, f.certain_max_m,
        f.certain_over_limit, per_robot);
    if (f.event.spec.kind != FaultSpec::Kind::kClockStep) continue;
    std::string heard;
    for (const auto& [robot, s] : f.heard_again_s)
      heard += fmt::format(" {}={:.2f}", robot, s);
    out += fmt::format(" heard_again_s:{} packets_refused={}", heard.empty() ? " none" : heard,
                       f.packets_refused);
  }
  return out;
}

std::string robustnessJson(const Robustness& r, const RobustnessOptions& o) {
  std::ostringstream j;
  j << "{\n";
  j << fmt::format(
      "  \"limit_m\": {}, \"tracking_samples\": {}, \"tracking_max_m\": {:.5f}, "
      "\"worst_robot\": {}, \"worst_t_s\": {:.3f},\n",
      o.limit_m, r.tracking_samples, r.tracking_max_m, r.worst_robot, r.worst_t);
  j << fmt::format(
      "  \"tracking_over_limit\": {}, \"tracking_p99_m\": {:.5f}, \"tracking_mean_m\": {:.5f}, "
      "\"not_tracking_share\": {:.5f},\n",
      r.tracking_over_limit, r.tracking_p99_m, r.tracking_mean_m, r.not_tracking_share);
  j << fmt::format(
      "  \"certain_max_m\": {:.5f}, \"certain_over_limit\": {}, \"twin_ambiguous_samples\": {},\n",
      r.certain_max_m, r.certain_over_limit, r.twin_ambiguous_samples);
  j << "  \"not_tracking_share_by_robot\": {";
  bool first = true;
  for (const auto& [robot, v] : r.not_tracking_share_by_robot) {
    j << fmt::format("{}\"{}\": {:.5f}", first ? "" : ", ", robot, v);
    first = false;
  }
  j << "},\n  \"vision_lines_hz\": {";
  first = true;
  for (const auto& [robot, hz] : r.vision_lines_hz) {
    j << fmt::format("{}\"{}\": {:.2f}", first ? "" : ", ", robot, hz);
    first = false;
  }
  j << "},\n  \"faults\": [";
  first = true;
  for (const FaultResult& f : r.faults) {
    j << (first ? "\n" : ",\n");
    first = false;
    j << fmt::format(
        "    {{\"fault\": \"{}\", \"start_s\": {:.3f}, \"end_s\": {:.3f}, \"processes\": {}, "
        "\"recovery_max_s\": {:.3f}, \"max_tracking_error_m\": {:.5f}, "
        "\"tracking_over_limit\": {}, \"certain_max_m\": {:.5f}, \"certain_over_limit\": {}, "
        "\"recovery_s\": {{",
        f.event.spec.text, f.event.start_t, f.event.end_t, f.event.processes, f.recovery_max_s,
        f.max_tracking_error_m, f.tracking_over_limit, f.certain_max_m, f.certain_over_limit);
    bool f1 = true;
    for (const auto& [robot, s] : f.recovery_s) {
      j << fmt::format("{}\"{}\": {:.3f}", f1 ? "" : ", ", robot, s);
      f1 = false;
    }
    j << "}";
    if (f.event.spec.kind == FaultSpec::Kind::kClockStep) {
      j << fmt::format(", \"step_s\": {}, \"packets_refused\": {}, \"heard_again_s\": {{",
                       f.event.spec.step_s, f.packets_refused);
      f1 = true;
      for (const auto& [robot, s] : f.heard_again_s) {
        j << fmt::format("{}\"{}\": {:.3f}", f1 ? "" : ", ", robot, s);
        f1 = false;
      }
      j << "}";
    }
    j << "}";
  }
  j << (r.faults.empty() ? "]\n" : "\n  ]\n");
  j << "}\n";
  return j.str();
}

}  // namespace fieldline::eval
