// Stages 3 and 4 of the mirror calibration at an unknown pose (pose_free_solver.hpp): the search
// over candidate mirrors and robot poses, and the poses of frames at one spot linked.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>

#include <fmt/core.h>
#include <Eigen/Dense>

#include "tools/calibration_common/staged_output.hpp"
#include "tools/mirror_calibrate/numbers.hpp"
#include "tools/mirror_calibrate/pose_free_solver.hpp"

namespace fieldline::calibration::posefree {

namespace {

bool finitePose(const Pose2& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.phi);
}

// Iteratively reweighted Gauss-Newton on the pose (Geman-McClure weights, scale tau).
Pose2 refinePose(const std::vector<Vec2>& pts, Pose2 pose, const field::DistanceGrid& grid,
                 double tau, int iterations) {
  for (int it = 0; it < iterations && finitePose(pose); ++it) {
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    const double c = std::cos(pose.phi), s = std::sin(pose.phi);
    for (const Vec2& p : pts) {
      const Vec2 rot(c * p.x() - s * p.y(), s * p.x() + c * p.y());
      const Vec2 f = pose.position() + rot;
      const double d = grid.distance(f);
      const Vec2 grad = grid.gradient(f);
      const double w = tau * tau / ((d * d + tau * tau) * (d * d + tau * tau)) * tau * tau;
      const Eigen::Vector3d j(grad.x(), grad.y(), grad.x() * -rot.y() + grad.y() * rot.x());
      a += w * j * j.transpose();
      g += w * j * d;
    }
    a.diagonal().array() += 1e-6;
    const Eigen::Vector3d step = a.ldlt().solve(-g);
    if (!step.allFinite()) break;
    pose.x += step(0);
    pose.y += step(1);
    pose.phi = geometry::normalizeAngle(pose.phi + step(2));
    if (step.head<2>().norm() < 1e-4 && std::abs(step(2)) < 1e-4) break;
  }
  return pose;
}

// Robot-frame floor points of a frame's ridge pixels within `max_radius` of the centre under a
// candidate mirror (no offset). The same pixels for every candidate, so that a candidate cannot
// fit better by mapping the awkward ones out of range: a pixel the candidate puts beyond
// `max_distance` (or nowhere) stays, far off every line.
std::vector<Vec2> candidatePoints(const std::vector<LinePx>& px, int frame, const Candidate& c,
                                  const camera::MirrorParams& base, double max_radius,
                                  double max_distance, std::size_t limit) {
  std::vector<Vec2> all;
  for (const LinePx& p : px) {
    if (p.frame != frame || p.radius > max_radius) continue;
    double d = c.s * base.distance.floorDistance(p.radius / c.k, p.bearing);
    if (!std::isfinite(d) || d > max_distance) d = 1000.0;
    all.emplace_back(d * std::cos(p.bearing), d * std::sin(p.bearing));
  }
  if (all.size() <= limit || limit == 0) return all;
  std::vector<Vec2> out;
  const double stride = static_cast<double>(all.size()) / static_cast<double>(limit);
  for (std::size_t i = 0; i < limit; ++i)
    out.push_back(all[static_cast<std::size_t>(static_cast<double>(i) * stride)]);
  return out;
}

}  // namespace

CostRaster::CostRaster(const field::FieldModel& field, double truncation, double cell,
                       double margin)
    : cell_(cell) {
  const Vec2 half = field.carpetHalfExtent() + Vec2(margin, margin);
  origin_ = -half;
  cols_ = static_cast<int>(std::ceil(2 * half.x() / cell)) + 1;
  rows_ = static_cast<int>(std::ceil(2 * half.y() / cell)) + 1;
  const field::DistanceGrid grid(field, cell, margin + 1.0);
  cost_.resize(static_cast<std::size_t>(cols_) * rows_);
  const double t2 = truncation * truncation;
  for (int j = 0; j < rows_; ++j) {
    for (int i = 0; i < cols_; ++i) {
      const double d = grid.distance(origin_ + cell * Vec2(i, j));
      cost_[static_cast<std::size_t>(j) * cols_ + i] = static_cast<float>(std::min(d * d, t2) / t2);
    }
  }
}

// Geman-McClure cost of points seen from `pose` (field frame), mean over points.
double poseCost(const std::vector<Vec2>& pts, const Pose2& pose, const field::DistanceGrid& grid,
                double tau) {
  if (pts.empty() || !finitePose(pose)) return 1.0;
  double sum = 0.0;
  const double c = std::cos(pose.phi), s = std::sin(pose.phi);
  for (const Vec2& p : pts) {
    const Vec2 f(pose.x + c * p.x() - s * p.y(), pose.y + s * p.x() + c * p.y());
    const double d = grid.distance(f);
    sum += d * d / (d * d + tau * tau);
  }
  return sum / static_cast<double>(pts.size());
}

std::vector<Vec2> evenlySpread(const std::vector<Vec2>& pts, std::size_t limit) {
  if (pts.size() <= limit) return pts;
  std::vector<Vec2> some;
  for (std::size_t i = 0; i < limit; ++i)
    some.push_back(pts[i * pts.size() / limit]);
  return some;
}

PlacingPoints placingPoints(const std::vector<Vec2>& pts, const PoseFreeParams& params) {
  PlacingPoints out;
  const std::size_t want = static_cast<std::size_t>(2 * params.search_points);
  for (std::size_t i = 0; i < want && !pts.empty(); ++i)
    out.coarse.push_back(pts[i * pts.size() / want]);
  // At most 600, evenly spread (a frame with fewer keeps its own: indexing 600 of them read past
  // the end of a shorter list, garbage points that stopped the calibration).
  out.dense = evenlySpread(pts, 600);
  return out;
}

std::vector<ScoredPose> placeFrame(const std::vector<Vec2>& pts, const CostRaster& raster,
                                   const field::DistanceGrid& grid, const field::FieldModel& field,
                                   const PoseFreeParams& params, int keep) {
  const PlacingPoints use = placingPoints(pts, params);
  return searchPoses(use.coarse, use.dense, raster, grid, field, params, keep);
}

std::vector<Vec2> finitePoints(const std::vector<Vec2>& pts, int& refused) {
  std::vector<Vec2> out;
  out.reserve(pts.size());
  for (const Vec2& p : pts) {
    if (p.allFinite()) {
      out.push_back(p);
    } else {
      ++refused;
    }
  }
  return out;
}

Pose2 twinOf(const Pose2& p) {
  return {-p.x, -p.y, geometry::normalizeAngle(p.phi + kPi)};
}

// The best distinct poses of one frame's points: lattice, then the best refined.
std::vector<ScoredPose> searchPoses(const std::vector<Vec2>& pts, const std::vector<Vec2>& dense,
                                    const CostRaster& raster, const field::DistanceGrid& grid,
                                    const field::FieldModel& field, const PoseFreeParams& params,
                                    int keep) {
  std::vector<ScoredPose> lattice;
  if (pts.size() < 10) return lattice;
  // The robot stands on the field (the docs ask for it): within its lines and a little beyond.
  const Vec2 half(field.length() / 2 + 0.3, field.width() / 2 + 0.3);
  const int headings = static_cast<int>(std::lround(360.0 / params.search_heading_step_deg));
  const double step = params.search_position_step;
  // The K best lattice poses (a small sorted list), with early exit beyond the K-th.
  const std::size_t kBest = 16;
  std::vector<Vec2> rot(pts.size());
  const double n = static_cast<double>(pts.size());
  for (int h = 0; h < headings; ++h) {
    const double phi = 2 * kPi * h / headings;
    const double c = std::cos(phi), s = std::sin(phi);
    for (std::size_t i = 0; i < pts.size(); ++i)
      rot[i] = Vec2(c * pts[i].x() - s * pts[i].y(), s * pts[i].x() + c * pts[i].y());
    // x >= 0 only: the field's symmetric twin covers the other half.
    for (double x = 0.0; x <= half.x() + 1e-9; x += step) {
      for (double y = -half.y(); y <= half.y() + 1e-9; y += step) {
        const double bound =
            lattice.size() < kBest ? n : lattice.back().cost * n;  // costs stored as sums here
        double sum = 0.0;
        for (const Vec2& p : rot) {
          sum += raster.at(x + p.x(), y + p.y());
          if (sum >= bound) break;
        }
        if (sum >= bound) continue;
        ScoredPose sp{{x, y, geometry::normalizeAngle(phi)}, sum / n};
        const auto at = std::upper_bound(
            lattice.begin(), lattice.end(), sp,
            [](const ScoredPose& a, const ScoredPose& b) { return a.cost < b.cost; });
        lattice.insert(at, sp);
        if (lattice.size() > kBest) lattice.pop_back();
      }
    }
  }
  // Refine, then keep distinct poses (the twin counts as the same).
  std::vector<ScoredPose> refined;
  for (const ScoredPose& l : lattice) {
    Pose2 p = refinePose(dense, l.pose, grid, 0.4, 8);
    p = refinePose(dense, p, grid, 0.15, 8);
    if (!finitePose(p)) continue;
    refined.push_back({p, poseCost(dense, p, grid, 0.15)});
  }
  std::sort(refined.begin(), refined.end(),
            [](const ScoredPose& a, const ScoredPose& b) { return a.cost < b.cost; });
  std::vector<ScoredPose> out;
  for (const ScoredPose& r : refined) {
    bool same = false;
    for (const ScoredPose& o : out) {
      for (const Pose2& t : {o.pose, twinOf(o.pose)}) {
        if ((t.position() - r.pose.position()).norm() < 0.3 &&
            std::abs(geometry::angleDiff(t.phi, r.pose.phi)) < 0.1) {
          same = true;
        }
      }
    }
    if (!same) out.push_back(r);
    if (static_cast<int>(out.size()) >= keep) break;
  }
  return out;
}

GroupPoses linkGroup(const std::vector<int>& members,
                     const std::vector<std::vector<ScoredPose>>& found) {
  struct Option {
    std::vector<Pose2> poses;
    double total;
    Vec2 at;
  };
  std::vector<Option> options;
  for (int anchorFrame : members) {
    for (const ScoredPose& a : found[static_cast<std::size_t>(anchorFrame)]) {
      for (const Pose2& anchor : {a.pose, twinOf(a.pose)}) {
        Option o{{}, 0.0, anchor.position()};
        for (int m : members) {
          double bestM = 2.0;
          Pose2 pick = anchor;
          for (const ScoredPose& c : found[static_cast<std::size_t>(m)]) {
            for (const Pose2& p : {c.pose, twinOf(c.pose)}) {
              const double apart = (p.position() - anchor.position()).norm();
              const double cost = c.cost + (apart < 0.6 ? apart : 1.0);
              if (cost < bestM) {
                bestM = cost;
                pick = p;
              }
            }
          }
          o.total += bestM;
          o.poses.push_back(pick);
        }
        o.total /= static_cast<double>(members.size());
        options.push_back(o);
      }
    }
  }
  GroupPoses g;
  for (const Option& o : options) {
    if (o.total < g.total) {
      g.total = o.total;
      g.poses = o.poses;
    }
  }
  if (g.poses.empty()) return g;
  const Vec2 at = g.poses.front().position();
  for (const Option& o : options) {
    if ((o.at - at).norm() >= 1.0 && (o.at + at).norm() >= 1.0) {
      g.alternative = std::min(g.alternative, o.total);
    }
  }
  return g;
}

void Solver::searchMirrors() {
  grid.emplace(field, 0.02, 3.0);
  raster.emplace(field, params.search_truncation, 0.05, 4.0);
  std::vector<Candidate> candidates;
  for (double k : params.radius_scales) {
    for (double s : params.distance_scales)
      candidates.push_back({k, s});
  }
  out.search.candidates = static_cast<int>(candidates.size());
  // The pixels every candidate is scored on: out to where the base camera sees
  // search_max_distance (at most 85 % of the usable radius).
  search_radius = std::min(0.85 * usable_radius,
                           std::isfinite(base.distance.imageRadius(params.search_max_distance, 0.0))
                               ? base.distance.imageRadius(params.search_max_distance, 0.0)
                               : usable_radius);
  // Frames the candidates are compared on first: those with the most ridges.
  std::vector<int> order(static_cast<std::size_t>(nf));
  for (int f = 0; f < nf; ++f)
    order[static_cast<std::size_t>(f)] = f;
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return per_frame[static_cast<std::size_t>(a)] > per_frame[static_cast<std::size_t>(b)];
  });
  const int firstFrames = std::min(nf, std::max(1, params.search_frames));
  std::vector<std::pair<double, std::size_t>> firstScores;
  const std::vector<int> first(order.begin(), order.begin() + firstFrames);
  for (std::size_t i = 0; i < candidates.size(); ++i)
    firstScores.emplace_back(scoreCandidate(candidates[i], first, 1, nullptr), i);
  std::sort(firstScores.begin(), firstScores.end());
  std::vector<int> all(static_cast<std::size_t>(nf));
  for (int f = 0; f < nf; ++f)
    all[static_cast<std::size_t>(f)] = f;
  double best = std::numeric_limits<double>::infinity();
  double second = best;
  const std::size_t survivors =
      std::min(firstScores.size(), static_cast<std::size_t>(std::max(1, params.search_survivors)));
  for (std::size_t i = 0; i < survivors; ++i) {
    std::vector<std::vector<ScoredPose>> poses(static_cast<std::size_t>(nf));
    const Candidate& c = candidates[firstScores[i].second];
    const double score = scoreCandidate(c, all, 4, &poses);
    if (score < best) {
      second = best;
      best = score;
      winner = c;
      winner_poses = std::move(poses);
    } else {
      second = std::min(second, score);
    }
  }
  if (params.verbose) printSearch(candidates, firstScores, best);
  out.search.radius_scale = winner.k;
  out.search.distance_scale = winner.s;
  out.search.score = best;
  out.search.runner_up = second;
  if (!(best < 0.75)) {
    throw Refusal(fmt::format(
        "the frames' line pixels fit no pose on field '{}' under any candidate mirror (best mean "
        "cost {:.2f}, 0 = every pixel on a line, 1 = none): frames of another field, or no "
        "field lines in view",
        field.name(), best));
  }
}

double Solver::scoreCandidate(const Candidate& c, const std::vector<int>& use, int keep,
                              std::vector<std::vector<ScoredPose>>* poses) const {
  double total = 0.0;
  for (int f : use) {
    const std::vector<Vec2> coarse = finitePoints(
        candidatePoints(pixels, f, c, base, search_radius, 4.0 * params.search_max_distance,
                        static_cast<std::size_t>(params.search_points)),
        non_finite_points);
    const std::vector<Vec2> dense = finitePoints(
        candidatePoints(pixels, f, c, base, search_radius, 4.0 * params.search_max_distance, 400),
        non_finite_points);
    std::vector<ScoredPose> found = searchPoses(coarse, dense, *raster, *grid, field, params, keep);
    total += found.empty() ? 1.0 : found.front().cost;
    if (poses) (*poses)[static_cast<std::size_t>(f)] = std::move(found);
  }
  return total / static_cast<double>(use.size());
}

void Solver::printSearch(const std::vector<Candidate>& candidates,
                         const std::vector<std::pair<double, std::size_t>>& firstScores,
                         double best) const {
  for (int f = 0; f < nf; ++f) {
    fmt::print(stderr, "frame {}:", f);
    for (const ScoredPose& p : winner_poses[static_cast<std::size_t>(f)])
      fmt::print(stderr, " ({:.2f},{:.2f},{:.0f} c{:.3f})", p.pose.x, p.pose.y,
                 p.pose.phi * 180 / kPi, p.cost);
    fmt::print(stderr, "\n");
  }
  for (auto& [sc, i] : firstScores)
    fmt::print(stderr, "cand k{:.2f} s{:.2f}: {:.3f}\n", candidates[i].k, candidates[i].s, sc);
  fmt::print(stderr, "winner k{:.2f} s{:.2f}: {:.3f}\n", winner.k, winner.s, best);
}

// Groups: a spot's frames, or a frame on its own.
void Solver::groupFrames() {
  spot_of.assign(static_cast<std::size_t>(nf), -1);
  {
    std::map<int, std::vector<int>> spots;
    for (int f = 0; f < nf; ++f) {
      if (frames[static_cast<std::size_t>(f)].spot >= 0) {
        spots[frames[static_cast<std::size_t>(f)].spot].push_back(f);
      } else {
        groups.push_back({f});
      }
    }
    int index = 0;
    for (const auto& [id, members] : spots) {
      for (int m : members)
        spot_of[static_cast<std::size_t>(m)] = index;
      groups.push_back(members);
      ++index;
    }
  }
  nspots = static_cast<int>(std::count_if(groups.begin(), groups.end(), [&](const auto& g) {
    return spot_of[static_cast<std::size_t>(g[0])] >= 0;
  }));
}

// Every group's poses linked; the groups by how well the search placed them: the joint fit
// starts from one of them.
void Solver::startPoses() {
  start.assign(static_cast<std::size_t>(nf), Pose2{});
  active.assign(static_cast<std::size_t>(nf), false);
  {
    std::vector<GroupPoses> linked;
    for (const std::vector<int>& g : groups)
      linked.push_back(linkGroup(g, winner_poses));
    for (std::size_t gi = 0; gi < groups.size(); ++gi) {
      const GroupPoses& lp = linked[gi];
      for (std::size_t i = 0; i < groups[gi].size(); ++i) {
        const int f = groups[gi][i];
        if (frames[static_cast<std::size_t>(f)].pose) {
          start[static_cast<std::size_t>(f)] = *frames[static_cast<std::size_t>(f)].pose;
          active[static_cast<std::size_t>(f)] = true;
        } else if (!lp.poses.empty()) {
          start[static_cast<std::size_t>(f)] = lp.poses[i];
        }
      }
      if (!lp.poses.empty()) seeds.emplace_back(lp.total, gi);
    }
    std::sort(seeds.begin(), seeds.end());
    if (seeds.empty() && std::none_of(active.begin(), active.end(), [](bool a) { return a; })) {
      throw Refusal("no pose on the field fits the frames' line pixels");
    }
  }
}

}  // namespace fieldline::calibration::posefree
