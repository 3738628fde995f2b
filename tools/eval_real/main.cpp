// fieldline-eval-real: runs every real case and rendered venue case and prints one line of
// figures per case (docs/calibration.md, "Real and venue cases").
#include <cstdio>
#include <exception>
#include <string>

#include <fmt/core.h>
#include <CLI/CLI.hpp>

#include "tools/eval_real/venue_cases.hpp"

int main(int argc, char** argv) {
  CLI::App app{"Runs the real and rendered venue cases and prints one line of figures per case"};
  std::string venueCase, folder;
  app.add_option("--write-venue", venueCase, "render this venue case's frames ...");
  app.add_option("--into", folder, "... into this folder (PNG frames and truth.yaml)");
  CLI11_PARSE(app, argc, argv);
  try {
    const auto v = fieldline::venue::renderVenue(fieldline::venue::loadVenueCase(venueCase));
    for (const std::string& p : fieldline::venue::writeVenue(v, folder))
      fmt::print("wrote {}\n", p);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fieldline-eval-real: %s\n", e.what());
    return 2;
  }
}
