// fieldline-eval-features: feature recognition on rendered frames over the whole field (the
// evaluation is the library in eval_features.hpp).
//
//   fieldline-eval-features --frames 3000 --out build/eval_features
//   fieldline-eval-features --frames 3000 --frame 318 --image f318.png --dump f318.csv
//   fieldline-eval-features --pose 1,0.5,0.3 --dump points.csv     (one frame's line points)
//   fieldline-eval-features --config my_evaluation.ini              (options from a file)
#include <exception>
#include <iostream>

#include "common/cli/cli.hpp"
#include "tools/eval_features/eval_features.hpp"

namespace cli = fieldline::cli;

int main(int argc, char** argv) {
  cli::App app{
      "Evaluates feature recognition on rendered frames over the whole field: detection rates, "
      "false pose hypotheses and pose errors. Exit code 1 when a hypothesis is false or a "
      "required rate is missed."};
  fieldline::eval_features::Options options;
  fieldline::eval_features::addOptions(app, options);
  try {
    app.parse(argc, argv);
  } catch (const cli::ParseError& e) {
    // --help exits 0; bad arguments exit 2.
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    return fieldline::eval_features::run(options);
  } catch (const std::exception& e) {
    std::cerr << "fieldline-eval-features: " << e.what() << "\n";
    return 2;
  }
}
