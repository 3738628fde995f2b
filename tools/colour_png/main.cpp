// fieldline-colour-png: writes the colour classification of an image as a PNG, each pixel in
// the display colour of its class, and prints how many pixels fell into each class.
//
//   fieldline-colour-png --in frame.png --out classes.png [--table colours_sim]
//   fieldline-colour-png --in frame.yuyv --yuyv 320x240 --out classes.png --side-by-side
#include <array>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/core.h>
#include <opencv2/core.hpp>

#include "common/camera/colour.hpp"
#include "common/camera/image_io.hpp"
#include "common/cli/cli.hpp"
#include "common/config/config.hpp"

namespace cli = fieldline::cli;
namespace camera = fieldline::camera;

namespace {

// "320x240" -> {320, 240}.
std::array<int, 2> parseSize(const std::string& text) {
  int w = 0;
  int h = 0;
  char x = 0;
  if (std::sscanf(text.c_str(), "%d%c%d", &w, &x, &h) != 3 || x != 'x' || w <= 0 || h <= 0 ||
      w % 2 != 0) {
    throw std::invalid_argument("--yuyv expects WIDTHxHEIGHT with an even width, got " + text);
  }
  return {w, h};
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{"Write the colour classification of an image (PNG/JPEG/BMP, or raw YUYV) as a PNG"};
  std::string input;
  std::string output;
  std::string table_name = "colours_sim";
  std::string yuyv_size;
  bool side_by_side = false;
  app.add_option("--in", input, "Input image: PNG/JPEG/BMP, or raw YUYV bytes with --yuyv")
      ->required()
      ->check(cli::ExistingFile);
  app.add_option("--out", output, "Output PNG")->required();
  app.add_option("--table", table_name, "Colour table preset (config/camera/<name>.yaml) or path")
      ->capture_default_str();
  app.add_option("--yuyv", yuyv_size,
                 "Treat the input as raw YUYV 4:2:2 of this size, e.g. 320x240");
  app.add_flag("--side-by-side", side_by_side, "Put the input (as BGR) left of the classes");
  FIELDLINE_CLI_PARSE(app, argc, argv);

  camera::ColourTable table;
  fieldline::config::runOrExit([&] { table = camera::loadColourTablePreset(table_name); });
  try {
    cv::Mat bgr;
    std::vector<std::uint8_t> raw;
    camera::FrameView frame;
    if (!yuyv_size.empty()) {
      const auto [w, h] = parseSize(yuyv_size);
      std::ifstream in(input, std::ios::binary);
      raw.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
      if (raw.size() != static_cast<std::size_t>(2 * w) * h) {
        throw std::runtime_error(fmt::format("{}: {} bytes, expected {} for {}x{} YUYV", input,
                                             raw.size(), 2 * w * h, w, h));
      }
      frame = {raw.data(), w, h, 2 * w, camera::PixelFormat::kYuyv};
    } else {
      bgr = camera::readBgrImage(input);
      frame = camera::viewOfBgr(bgr);
    }
    cv::Mat classes = camera::classificationImage(frame, table);
    std::array<long, camera::kColourClassCount> counts{};
    for (int v = 0; v < frame.height; ++v) {
      for (int u = 0; u < frame.width; ++u) {
        ++counts[static_cast<std::size_t>(table.classifyPixel(frame, u, v))];
      }
    }
    if (side_by_side) {
      cv::Mat both;
      cv::hconcat(camera::toBgrImage(frame), classes, both);
      classes = both;
    }
    camera::writeImage(output, classes);
    const double total = static_cast<double>(frame.width) * frame.height;
    for (int c = 0; c < camera::kColourClassCount; ++c) {
      fmt::print("{:8s} {:6.2f} %\n", camera::colourName(static_cast<camera::ColourClass>(c)),
                 100.0 * counts[static_cast<std::size_t>(c)] / total);
    }
  } catch (const std::exception& e) {
    fmt::print(stderr, "fieldline-colour-png: {}\n", e.what());
    return 1;
  }
  return 0;
}
