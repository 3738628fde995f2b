// fieldline-eval-real: runs every real case (tests/data/real_cases/*.yaml, data in
// ../shared/data/real) and every rendered venue case (tests/data/venue_cases/*.yaml) through the
// tools a team uses and prints one line of figures per case (docs/calibration.md, "Real and venue
// cases"). Exit codes: 0 every case met its expectations, 1 one did not, 2 bad arguments or
// manifest, 77 every case was skipped (the real data is not beside the repository).
//
//   fieldline-eval-real                      # all cases
//   fieldline-eval-real --real-only          # the real cases only (seconds)
//   fieldline-eval-real --case cnc_rings --case grey_carpet   # the ctest eval_real_cases
//   fieldline-eval-real --write-venue tests/data/venue_cases/grey_carpet.yaml --into /tmp/grey
#include <algorithm>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include <fmt/core.h>

#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "tools/eval_real/eval_real.hpp"
#include "tools/eval_real/venue_cases.hpp"

namespace cli = fieldline::cli;

namespace {

int writeVenue(const std::string& manifest, const std::string& folder) {
  const auto v = fieldline::venue::renderVenue(fieldline::venue::loadVenueCase(manifest));
  for (const std::string& p : fieldline::venue::writeVenue(v, folder))
    fmt::print("wrote {}\n", p);
  fmt::print("wrote {}/truth.yaml\n", folder);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Runs the real cases (data kept beside the repository) and the rendered venue cases "
      "through the calibration tools and the localizer; one line of figures per case"};
  app.footer(
      "Cases: real (kind rings, line_points, field_points; data under ../shared/data/real, "
      "skipped when absent) and rendered venue cases (mirror from the shipped preset at an "
      "unknown pose, colours from the frames, line points scored against the truth). Each case "
      "prints one line of figures and FAIL with the broken `expect:` bound.\n"
      "Exit: 0 every case run met its expectations, 1 a case failed, 2 bad arguments or "
      "manifest, or no case matched, 77 every case was skipped.\n"
      "Procedure and figures: docs/calibration.md.");
  const std::string root = fieldline::config::projectRoot();
  std::string realDir = root + "/tests/data/real_cases";
  std::string venueDir = root + "/tests/data/venue_cases";
  std::vector<std::string> only;
  std::string venueCase, folder;
  bool realOnly = false, venueOnly = false;
  app.add_option("--real", realDir, "folder of real case manifests")->capture_default_str();
  app.add_option("--venue", venueDir, "folder of venue case manifests")->capture_default_str();
  app.add_flag("--real-only", realOnly, "only the real cases");
  app.add_flag("--venue-only", venueOnly, "only the venue cases");
  app.add_option("--case", only,
                 "only the cases of these names (manifest file names without .yaml; repeatable)");
  app.add_option("--write-venue", venueCase, "render a venue case's frames (with --into)");
  app.add_option("--into", folder, "folder for --write-venue (PNG frames and truth.yaml)");
  FIELDLINE_CLI_PARSE(app, argc, argv);
  try {
    if (!venueCase.empty()) {
      if (folder.empty()) throw std::invalid_argument("--write-venue needs --into FOLDER");
      return writeVenue(venueCase, folder);
    }
    std::vector<std::string> manifests;
    if (!venueOnly) {
      for (const std::string& m : fieldline::evalreal::manifestsIn(realDir))
        manifests.push_back(m);
    }
    if (!realOnly) {
      for (const std::string& m : fieldline::evalreal::manifestsIn(venueDir))
        manifests.push_back(m);
    }
    int failed = 0, skipped = 0, run = 0;
    for (const std::string& m : manifests) {
      const std::string stem = std::filesystem::path(m).stem().string();
      if (!only.empty() && std::find(only.begin(), only.end(), stem) == only.end()) continue;
      const fieldline::evalreal::CaseResult r = fieldline::evalreal::runCase(m);
      ++run;
      const char* status = r.skipped ? "skip" : r.failed.empty() ? "ok" : "FAIL";
      fmt::print("{:<12s} {:<26s} {:<4s} {:6.1f} s  {}\n", r.kind, r.name, status, r.seconds,
                 r.figures);
      for (const std::string& f : r.failed)
        fmt::print("{:>47s}expected: {}\n", "", f);
      std::fflush(stdout);
      failed += r.failed.empty() ? 0 : 1;
      skipped += r.skipped ? 1 : 0;
    }
    if (run == 0) throw std::invalid_argument("no case to run");
    fmt::print("{} cases: {} met their expectations, {} failed, {} skipped\n", run,
               run - failed - skipped, failed, skipped);
    if (skipped == run) {
      fmt::print(
          "every case was skipped: its data (real cases: beside the repository, {}) or "
          "its field preset is not there\n",
          realDir);
      return 77;
    }
    return failed > 0 ? 1 : 0;
  } catch (const fieldline::config::Error& e) {
    std::fprintf(stderr, "config error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fieldline-eval-real: %s\n", e.what());
    return 2;
  }
}
