// fieldline-replay-features: feature recognition's per-message work (FeatureRecognizer::recognize
// on a VISION_LINES message's points) on the line frames of a recording of the running team, with
// the caches warm (a frame's fastest of several rounds) or cold (before every frame a buffer of
// --evict-mb MB is written, as the other processes of a team on a shared machine do between two
// of a process's messages). The same method as fieldline-replay-tracking (issue 32).
//
//   fieldline-record --robot 1 --channel VISION_LINES -o REC
//   fieldline-replay-features --log REC/robot1.lcm [--evict-mb 64] [--rounds 5]
//
// Prints the median, mean and p90 of a frame's recognize() in us (the first frame left out).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "bench/replay_summary.hpp"
#include "common/bus/channels.hpp"
#include "common/bus/checked_decode.hpp"
#include "common/bus/log_file.hpp"
#include "common/cli/cli.hpp"
#include "common/field/field_model.hpp"
#include "common/msg/line_contours.hpp"
#include "services/feature_recognition/recognizer.hpp"
#include "services/feature_recognition/settings.hpp"

namespace bus = fieldline::bus;
namespace cli = fieldline::cli;
namespace fr = fieldline::feature_recognition;
namespace perception = fieldline::perception;

namespace {

using Clock = std::chrono::steady_clock;

std::vector<perception::LinePoints> readLog(const std::string& path, int maxFrames) {
  bus::LogReader reader(path);
  bus::LogEvent event;
  std::vector<perception::LinePoints> frames;
  while (reader.nextEvent(event) && static_cast<int>(frames.size()) < maxFrames) {
    if (event.channel != bus::channels::kVisionLines.name) continue;
    fieldline::line_contours_t m;
    if (bus::decodeChecked(m, event.data.data(), static_cast<int>(event.data.size()))) continue;
    perception::LinePoints points;
    fieldline::msg::fromMessage(m, points);
    frames.push_back(std::move(points));
  }
  return frames;
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{"Feature recognition's per-message work on recorded line frames, warm or cold"};
  std::string log;
  std::string fieldName = "msl";
  int rounds = 5;
  int maxFrames = 600;
  double evictMb = 0;
  app.add_option("--log", log, "recording with VISION_LINES (a robot's bus)")->required();
  app.add_option("--field", fieldName, "field preset or YAML file")->capture_default_str();
  app.add_option("--rounds", rounds, "rounds; a frame's time is its fastest")
      ->check(cli::Range(1, 1000))
      ->capture_default_str();
  app.add_option("--frames", maxFrames, "at most this many frames")
      ->check(cli::Range(2, 1000000))
      ->capture_default_str();
  app.add_option("--evict-mb", evictMb, "write this many MB before every frame (0: warm)")
      ->check(cli::Range(0.0, 4096.0));
  FIELDLINE_CLI_PARSE(app, argc, argv);

  const fieldline::field::FieldModel field = fieldline::field::loadFieldPreset(fieldName);
  const fr::RecognitionParams params = fr::loadRecognitionPreset("default");
  const std::vector<perception::LinePoints> frames = readLog(log, maxFrames);
  std::printf("%zu line frames, %d rounds, evict %.0f MB\n", frames.size(), rounds, evictMb);
  if (frames.size() < 2) {
    std::fprintf(stderr, "fieldline-replay-features: %s holds %zu VISION_LINES frames, 2 needed\n",
                 log.c_str(), frames.size());
    return 1;
  }
  std::vector<std::uint8_t> evict(static_cast<std::size_t>(evictMb * 1e6));
  std::vector<double> fastest(frames.size(), 1e30);
  for (int r = 0; r < rounds; ++r) {
    fr::FeatureRecognizer recognizer(field, params);
    perception::FieldFeatures features;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      // One write a cache line.
      for (std::size_t k = 0; k < evict.size(); k += 64)
        evict[k] = static_cast<std::uint8_t>(evict[k] + 1);
      const Clock::time_point t0 = Clock::now();
      recognizer.recognize(frames[i], features);
      const double us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
      fastest[i] = std::min(fastest[i], us);
    }
  }
  fastest.erase(fastest.begin());
  fieldline::bench::printReplaySummary("recognize", fastest);
  return 0;
}
