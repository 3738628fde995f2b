#include "tools/eval/team_ball_budget.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

namespace fieldline::eval {

const char* budgetClassName(BudgetClass c) {
  switch (c) {
    case BudgetClass::kRestShared:
      return "resting, 2+ reporters";
    case BudgetClass::kRestLoneNear:
      return "resting, lone near reporter";
    case BudgetClass::kRestLoneFar:
      return "resting, lone far reporter";
    case BudgetClass::kRestReportedRolling:
      return "resting, reported rolling";
    case BudgetClass::kRollingShared:
      return "rolling, 2+ reporters";
    case BudgetClass::kRollingLoneNear:
      return "rolling, lone near reporter";
    case BudgetClass::kRollingLoneFar:
      return "rolling, lone far reporter";
    case BudgetClass::kCount:
      break;
  }
  return "?";
}

BudgetClass classifyPicture(const BudgetPicture& p, const BudgetOptions& options) {
  const bool lone = p.used.size() == 1;
  const bool far = lone && p.used.front().range_m >= options.far_m;
  if (p.true_speed_mps >= options.rest_speed_mps) {
    if (!lone) return BudgetClass::kRollingShared;
    return far ? BudgetClass::kRollingLoneFar : BudgetClass::kRollingLoneNear;
  }
  const bool all_rolling =
      !p.used.empty() && std::all_of(p.used.begin(), p.used.end(), [&](const BudgetReporter& r) {
        return r.reported_speed_mps >= options.rest_speed_mps;
      });
  if (all_rolling) return BudgetClass::kRestReportedRolling;
  if (!lone) return BudgetClass::kRestShared;
  return far ? BudgetClass::kRestLoneFar : BudgetClass::kRestLoneNear;
}

double TeamBallBudget::contribution(BudgetClass c) const {
  return pictures == 0 ? 0.0 : row(c).error_sum_m / static_cast<double>(pictures);
}

double TeamBallBudget::mean() const {
  double sum = 0;
  for (const BudgetRow& r : rows)
    sum += r.error_sum_m;
  return pictures == 0 ? 0.0 : sum / static_cast<double>(pictures);
}

TeamBallBudget teamBallBudget(const std::vector<BudgetPicture>& pictures,
                              const std::vector<TruthSample>& truth, const BudgetOptions& options) {
  const std::vector<Utime> put_backs = putBackTimes(truth);
  TeamBallBudget b;
  for (const BudgetPicture& p : pictures) {
    if (justAfterPutBack(put_backs, p.utime, options.put_back_blind_us) || p.used.empty()) {
      ++b.left_out;
      continue;
    }
    ++b.pictures;
    BudgetRow& row = b.rows[static_cast<std::size_t>(classifyPicture(p, options))];
    ++row.pictures;
    row.error_sum_m += p.team_error_m;
    if (p.team_error_m > options.large_error_m) row.large_error_sum_m += p.team_error_m;
    double best = std::numeric_limits<double>::infinity();
    for (const BudgetReporter& r : p.used) {
      if (std::isfinite(r.error_at_stamp_m)) best = std::min(best, r.error_at_stamp_m);
    }
    if (std::isfinite(best)) {
      row.best_reporter_sum_m += best;
      ++row.best_reporter_pictures;
    }
  }
  return b;
}

std::string budgetTable(const TeamBallBudget& b, const BudgetOptions& options) {
  std::string out = fmt::format(
      "team ball budget: {} scored pictures ({} left out), mean {:.4f} m; per class: pictures, "
      "share, mean m, part of the run's mean m, of it from pictures over {:.2f} m, best used "
      "reporter's error at its stamp m\n",
      b.pictures, b.left_out, b.mean(), options.large_error_m);
  const double n = static_cast<double>(std::max<std::size_t>(b.pictures, 1));
  for (std::size_t i = 0; i < b.rows.size(); ++i) {
    const BudgetRow& r = b.rows[i];
    if (r.pictures == 0) continue;
    const double k = static_cast<double>(r.pictures);
    out += fmt::format("  {:28s} {:5d} {:.3f} {:.4f} {:.4f} {:.4f} {:.4f}\n",
                       budgetClassName(static_cast<BudgetClass>(i)), r.pictures, k / n,
                       r.error_sum_m / k, r.error_sum_m / n, r.large_error_sum_m / n,
                       r.best_reporter_pictures == 0
                           ? std::numeric_limits<double>::quiet_NaN()
                           : r.best_reporter_sum_m / static_cast<double>(r.best_reporter_pictures));
  }
  return out;
}

}  // namespace fieldline::eval
