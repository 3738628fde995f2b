#include "common/camera/colour.hpp"

#include <algorithm>
#include <array>

namespace fieldline::camera {
namespace {

constexpr std::array<std::string_view, kColourClassCount> kNames = {
    "green", "white", "yellow", "blue", "orange", "black", "unknown"};

// Value at the centre of quantisation cell `cell` of one channel.
std::uint8_t cellCentre(int cell) {
  constexpr int step = 1 << (8 - ColourTable::kIndexBits);
  return static_cast<std::uint8_t>(cell * step + step / 2);
}

}  // namespace

std::string_view colourName(ColourClass colour) {
  const auto i = static_cast<std::size_t>(colour);
  return i < kNames.size() ? kNames[i] : "invalid";
}

std::optional<ColourClass> colourFromName(std::string_view name) {
  for (std::size_t i = 0; i < kNames.size(); ++i) {
    if (kNames[i] == name) return static_cast<ColourClass>(i);
  }
  return std::nullopt;
}

Bgr displayColour(ColourClass colour) {
  switch (colour) {
    case ColourClass::kGreen:
      return {40, 160, 40};
    case ColourClass::kWhite:
      return {255, 255, 255};
    case ColourClass::kYellow:
      return {0, 230, 255};
    case ColourClass::kBlue:
      return {230, 90, 20};
    case ColourClass::kOrange:
      return {0, 128, 255};
    case ColourClass::kBlack:
      return {0, 0, 0};
    case ColourClass::kUnknown:
      break;
  }
  return {128, 128, 128};
}

ColourTable::ColourTable()
    : yuv_(static_cast<std::size_t>(kCells), ColourClass::kUnknown),
      bgr_(static_cast<std::size_t>(kCells), ColourClass::kUnknown) {}

ColourTable::ColourTable(std::vector<YuvBox> boxes) : ColourTable() {
  boxes_ = std::move(boxes);
  constexpr int n = 1 << kIndexBits;
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) {
      for (int c = 0; c < n; ++c) {
        const std::uint8_t ca = cellCentre(a);
        const std::uint8_t cb = cellCentre(b);
        const std::uint8_t cc = cellCentre(c);
        yuv_[index(ca, cb, cc)] = classifyExact({ca, cb, cc});
        bgr_[index(ca, cb, cc)] = classifyExact(yuvFromBgr({ca, cb, cc}));
      }
    }
  }
}

ColourClass ColourTable::classifyExact(Yuv c) const {
  for (const YuvBox& box : boxes_) {
    if (box.contains(c)) return box.colour;
  }
  return ColourClass::kUnknown;
}

ColourClass ColourTable::classifyBlock(const FrameView& frame, int u0, int v0, int size) const {
  std::array<int, kColourClassCount> votes{};
  const int u_end = std::min(u0 + size, frame.width);
  const int v_end = std::min(v0 + size, frame.height);
  int counted = 0;
  for (int v = std::max(v0, 0); v < v_end; ++v) {
    for (int u = std::max(u0, 0); u < u_end; ++u) {
      ++votes[static_cast<std::size_t>(classifyPixel(frame, u, v))];
      ++counted;
    }
  }
  if (counted == 0) return ColourClass::kUnknown;
  const auto best = std::max_element(votes.begin(), votes.end());
  return static_cast<ColourClass>(best - votes.begin());
}

namespace {

std::array<std::uint8_t, 2> loadRange(const config::Node& box, const std::string& key) {
  const std::vector<int> range = box.getList<int>(key, 2);
  if (range[0] < 0 || range[1] > 255 || range[0] > range[1]) {
    box.fail(key, "expected [min, max] with 0 <= min <= max <= 255");
  }
  return {static_cast<std::uint8_t>(range[0]), static_cast<std::uint8_t>(range[1])};
}

}  // namespace

ColourTable loadColourTable(const config::Node& root) {
  const config::Node colours = root.child("colours");
  std::vector<YuvBox> boxes;
  for (const std::string& name : colours.keys()) {
    const std::optional<ColourClass> colour = colourFromName(name);
    if (!colour || *colour == ColourClass::kUnknown) {
      colours.fail(name,
                   "unknown colour class (expected green, white, yellow, blue, orange, black)");
    }
    for (const config::Node& box : colours.children(name)) {
      YuvBox b;
      b.colour = *colour;
      b.y = loadRange(box, "y");
      b.u = loadRange(box, "u");
      b.v = loadRange(box, "v");
      box.rejectUnknownKeys();
      boxes.push_back(b);
    }
  }
  colours.rejectUnknownKeys();
  return ColourTable(std::move(boxes));
}

ColourTable loadColourTablePreset(const std::string& name_or_path) {
  const config::Node root = config::Node::loadFile(config::resolvePreset("camera", name_or_path));
  ColourTable table = loadColourTable(root);
  root.rejectUnknownKeys();
  return table;
}

}  // namespace fieldline::camera
