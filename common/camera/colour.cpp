#include "common/camera/colour.hpp"

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <istream>
#include <ostream>
#include <sstream>
#include <stdexcept>

#include "common/config/paths.hpp"

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

std::uint64_t ColourTable::nextGeneration() {
  static std::atomic<std::uint64_t> last{0};
  return ++last;
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

ColourTable::ColourTable(std::vector<YuvBox> boxes, const ColourTable& fallback) : ColourTable() {
  if (!fallback.from_lookup_) {
    // Boxes all the way: the boxes, then the fallback's, first match wins.
    boxes.insert(boxes.end(), fallback.boxes_.begin(), fallback.boxes_.end());
    *this = ColourTable(std::move(boxes));
    return;
  }
  boxes_ = std::move(boxes);
  from_lookup_ = true;
  constexpr int n = 1 << kIndexBits;
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) {
      for (int c = 0; c < n; ++c) {
        const Yuv centre{cellCentre(a), cellCentre(b), cellCentre(c)};
        ColourClass k = ColourClass::kUnknown;
        for (const YuvBox& box : boxes_) {
          if (box.contains(centre)) {
            k = box.colour;
            break;
          }
        }
        const int i = index(centre.y, centre.u, centre.v);
        yuv_[i] = k != ColourClass::kUnknown ? k : fallback.yuv_[i];
      }
    }
  }
  fillBgrFromYuv();
}

ColourTable ColourTable::fromLookup(std::vector<ColourClass> yuv) {
  if (yuv.size() != static_cast<std::size_t>(kCells)) {
    throw std::invalid_argument("ColourTable::fromLookup: expected " + std::to_string(kCells) +
                                " cells, got " + std::to_string(yuv.size()));
  }
  for (const ColourClass c : yuv) {
    if (static_cast<int>(c) >= kColourClassCount) {
      throw std::invalid_argument("ColourTable::fromLookup: invalid class " +
                                  std::to_string(static_cast<int>(c)));
    }
  }
  ColourTable table;
  table.from_lookup_ = true;
  table.yuv_ = std::move(yuv);
  table.fillBgrFromYuv();
  return table;
}

void ColourTable::fillBgrFromYuv() {
  constexpr int n = 1 << kIndexBits;
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) {
      for (int c = 0; c < n; ++c) {
        const std::uint8_t ca = cellCentre(a), cb = cellCentre(b), cc = cellCentre(c);
        bgr_[index(ca, cb, cc)] = classifyYuv(yuvFromBgr({ca, cb, cc}));
      }
    }
  }
}

ColourClass ColourTable::classifyExact(Yuv c) const {
  if (from_lookup_) return classifyYuv(c);
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

namespace {

constexpr std::string_view kLutMagic = "fieldline-colour-lut 1";

std::string expectLine(std::istream& in, const std::string& name, std::string_view what) {
  std::string line;
  if (!std::getline(in, line)) {
    throw std::runtime_error(name + ": truncated header, expected " + std::string(what));
  }
  return line;
}

}  // namespace

void writeColourLookup(std::ostream& out, const ColourTable& table) {
  const std::vector<ColourClass>& cells = table.yuvLookup();
  std::string runs;
  std::size_t count = 0;
  for (std::size_t i = 0; i < cells.size();) {
    std::size_t j = i;
    while (j < cells.size() && cells[j] == cells[i])
      ++j;
    runs.push_back(static_cast<char>(cells[i]));
    for (std::size_t length = j - i;;) {
      const auto byte = static_cast<std::uint8_t>(length & 0x7f);
      length >>= 7;
      runs.push_back(static_cast<char>(length ? byte | 0x80 : byte));
      if (!length) break;
    }
    ++count;
    i = j;
  }
  out << kLutMagic << "\nbits " << ColourTable::kIndexBits << "\nclasses";
  for (int c = 0; c < kColourClassCount; ++c) {
    out << ' ' << colourName(static_cast<ColourClass>(c));
  }
  out << "\nruns " << count << '\n';
  out.write(runs.data(), static_cast<std::streamsize>(runs.size()));
}

ColourTable readColourLookup(std::istream& in, const std::string& name) {
  if (expectLine(in, name, kLutMagic) != kLutMagic) {
    throw std::runtime_error(name + ": not a colour lookup table (expected '" +
                             std::string(kLutMagic) + "' first)");
  }
  if (expectLine(in, name, "bits") != "bits " + std::to_string(ColourTable::kIndexBits)) {
    throw std::runtime_error(name + ": expected 'bits " + std::to_string(ColourTable::kIndexBits) +
                             "'");
  }
  std::istringstream classLine(expectLine(in, name, "classes"));
  std::string word;
  classLine >> word;
  if (word != "classes") throw std::runtime_error(name + ": expected the 'classes' line");
  std::vector<ColourClass> classes;
  while (classLine >> word) {
    const std::optional<ColourClass> c = colourFromName(word);
    if (!c) throw std::runtime_error(name + ": unknown class '" + word + "'");
    classes.push_back(*c);
  }
  std::istringstream runLine(expectLine(in, name, "runs"));
  long long runCount = -1;
  if (!(runLine >> word >> runCount) || word != "runs" || runCount < 1 ||
      runCount > ColourTable::kCells) {
    throw std::runtime_error(
        name + ": expected 'runs N' with 1 <= N <= " + std::to_string(ColourTable::kCells));
  }
  std::vector<ColourClass> cells;
  cells.reserve(static_cast<std::size_t>(ColourTable::kCells));
  for (long long r = 0; r < runCount; ++r) {
    const int id = in.get();
    if (id == std::char_traits<char>::eof()) {
      throw std::runtime_error(name + ": truncated at run " + std::to_string(r));
    }
    if (id >= static_cast<int>(classes.size())) {
      throw std::runtime_error(name + ": run " + std::to_string(r) + " has class " +
                               std::to_string(id) + ", the header names " +
                               std::to_string(classes.size()));
    }
    std::uint64_t length = 0;
    for (int shift = 0;; shift += 7) {
      const int byte = in.get();
      if (byte == std::char_traits<char>::eof() || shift > 28) {
        throw std::runtime_error(name + ": bad run length at run " + std::to_string(r));
      }
      length |= static_cast<std::uint64_t>(byte & 0x7f) << shift;
      if (!(byte & 0x80)) break;
    }
    if (length == 0 || cells.size() + length > static_cast<std::size_t>(ColourTable::kCells)) {
      throw std::runtime_error(name + ": run " + std::to_string(r) +
                               " is empty or runs past the table's " +
                               std::to_string(ColourTable::kCells) + " cells");
    }
    cells.insert(cells.end(), length, classes[static_cast<std::size_t>(id)]);
  }
  if (cells.size() != static_cast<std::size_t>(ColourTable::kCells)) {
    throw std::runtime_error(name + ": the runs cover " + std::to_string(cells.size()) + " of " +
                             std::to_string(ColourTable::kCells) + " cells");
  }
  if (in.get() != std::char_traits<char>::eof()) {
    throw std::runtime_error(name + ": bytes after the last run");
  }
  return ColourTable::fromLookup(std::move(cells));
}

void writeColourLookupFile(const std::string& path, const ColourTable& table) {
  std::ofstream out(path, std::ios::binary);
  writeColourLookup(out, table);
  out.close();
  if (!out) throw std::runtime_error("cannot write " + path);
}

ColourTable readColourLookupFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path);
  return readColourLookup(in, path);
}

ColourTable loadColourTable(const config::Node& root) {
  if (root.has("lookup_table")) {
    if (root.has("colours")) {
      root.fail("lookup_table", "give either colours (boxes) or lookup_table, not both");
    }
    const std::string path =
        config::resolveAgainst(root.file(), "", root.get<std::string>("lookup_table"));
    try {
      return readColourLookupFile(path);
    } catch (const std::exception& e) {
      root.fail("lookup_table", e.what());
    }
  }
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
