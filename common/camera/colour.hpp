// Colour classes of the RoboCup field (seed chapter 3: green, white, yellow, blue, orange,
// black) and a classification table that maps one pixel to its class with a single table
// lookup, for YUV and for BGR input.
//
// The table is configured as boxes in YUV (config/camera/colours_*.yaml) or as a full lookup
// table (a `.lut` file, see writeColourLookup; what the calibrator and the light adaptation
// produce); either way it becomes two 3-D lookup tables, one indexed by quantised (Y, U, V) and one
// by quantised (B, G, R), so classification costs the same for both input formats and no frame is
// converted. The quantisation is kIndexBits bits per channel (4 grey levels per cell at 6 bits): a
// box edge is honoured to within one cell.
//
// Usage (the region tracker):
//   const camera::ColourTable table = camera::loadColourTablePreset("colours_sim");
//   camera::FrameView frame{msg.data.data(), msg.width, msg.height, msg.stride,
//                           camera::PixelFormat::kYuyv};
//   if (table.classifyPixel(frame, u, v) == camera::ColourClass::kGreen) ...
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/camera/frame.hpp"
#include "common/config/config.hpp"

namespace fieldline::camera {

// Numbered as the seed lists the classes; kUnknown is everything no box claims.
enum class ColourClass : std::uint8_t {
  kGreen = 0,
  kWhite = 1,
  kYellow = 2,
  kBlue = 3,
  kOrange = 4,
  kBlack = 5,
  kUnknown = 6,
};
inline constexpr int kColourClassCount = 7;

// "green", "white", ..., "unknown".
std::string_view colourName(ColourClass colour);
// The class of a lower-case name; nullopt for anything else.
std::optional<ColourClass> colourFromName(std::string_view name);
// A typical display colour of each class (for the classification PNG and debug views).
Bgr displayColour(ColourClass colour);

// One box of the classification: a pixel whose Y, U and V all lie within the closed ranges
// belongs to `colour` (the first matching box in table order wins).
struct YuvBox {
  ColourClass colour = ColourClass::kUnknown;
  std::array<std::uint8_t, 2> y{0, 255};
  std::array<std::uint8_t, 2> u{0, 255};
  std::array<std::uint8_t, 2> v{0, 255};

  bool contains(Yuv c) const {
    return c.y >= y[0] && c.y <= y[1] && c.u >= u[0] && c.u <= u[1] && c.v >= v[0] && c.v <= v[1];
  }
};

class ColourTable {
 public:
  // Bits per channel of the lookup index: 2^18 cells, 256 KiB per table, fits in L2.
  static constexpr int kIndexBits = 6;
  static constexpr int kCells = 1 << (3 * kIndexBits);

  // Everything unknown.
  ColourTable();
  // Samples the boxes (first match wins) at the centre of every cell.
  explicit ColourTable(std::vector<YuvBox> boxes);
  // The boxes first; cells no box claims take the class of `fallback` (e.g. a lookup table's
  // other classes under freshly calibrated green and white).
  ColourTable(std::vector<YuvBox> boxes, const ColourTable& fallback);
  // A full lookup table: kCells classes indexed by quantised (Y, U, V) as index() orders them
  // (Y major). Throws std::invalid_argument for another size or an invalid class.
  static ColourTable fromLookup(std::vector<ColourClass> yuv);

  ColourClass classifyYuv(std::uint8_t y, std::uint8_t u, std::uint8_t v) const {
    return yuv_[index(y, u, v)];
  }
  ColourClass classifyYuv(Yuv c) const { return classifyYuv(c.y, c.u, c.v); }
  ColourClass classifyBgr(std::uint8_t b, std::uint8_t g, std::uint8_t r) const {
    return bgr_[index(b, g, r)];
  }
  ColourClass classifyBgr(Bgr c) const { return classifyBgr(c.b, c.g, c.r); }

  // The class of pixel (u, v) of a raw frame, read in place; (u, v) must lie inside the frame.
  ColourClass classifyPixel(const FrameView& frame, int u, int v) const {
    const std::uint8_t* row = frame.data + static_cast<std::ptrdiff_t>(v) * frame.stride;
    if (frame.format == PixelFormat::kYuyv) {
      const std::uint8_t* pair = row + static_cast<std::ptrdiff_t>(u >> 1) * 4;
      return classifyYuv(pair[(u & 1) * 2], pair[1], pair[3]);
    }
    const std::uint8_t* px = row + static_cast<std::ptrdiff_t>(u) * 3;
    return classifyBgr(px[0], px[1], px[2]);
  }

  // The most frequent class among the pixels of the block [u0, u0 + size) x [v0, v0 + size),
  // clipped to the frame; ties go to the lower class number. kUnknown for an empty block.
  ColourClass classifyBlock(const FrameView& frame, int u0, int v0, int size) const;

  // Exact box test without the quantisation of the lookup tables (for tests and tools).
  ColourClass classifyExact(Yuv c) const;

  // The boxes the table was made from (empty for a table made from a lookup table).
  const std::vector<YuvBox>& boxes() const { return boxes_; }
  // True when made by fromLookup (classifyExact then reads the lookup table).
  bool fromLookupTable() const { return from_lookup_; }
  // The YUV lookup table (kCells entries).
  const std::vector<ColourClass>& yuvLookup() const { return yuv_; }
  // Which classes the table holds: a table made anew (constructed, read, adapted) gets a number
  // no other table had; a copy keeps its source's. Users that keep a copy of the classes in
  // another layout (region tracking's ClassLookup) compare it to know when to take them again.
  std::uint64_t generation() const { return generation_; }

  // Index of a (Y, U, V) or (B, G, R) triple into the lookup tables.
  static int index(std::uint8_t a, std::uint8_t b, std::uint8_t c) {
    constexpr int shift = 8 - kIndexBits;
    return ((a >> shift) << (2 * kIndexBits)) | ((b >> shift) << kIndexBits) | (c >> shift);
  }

 private:
  // Fills bgr_ from yuv_ (each BGR cell centre converted to YUV and looked up).
  void fillBgrFromYuv();

  std::vector<YuvBox> boxes_;
  bool from_lookup_ = false;
  std::vector<ColourClass> yuv_;
  std::vector<ColourClass> bgr_;
  std::uint64_t generation_ = nextGeneration();
  static std::uint64_t nextGeneration();
};

// The lookup table file (`.lut`), compact and exact: a text header of four lines
//   fieldline-colour-lut 1
//   bits 6
//   classes green white yellow blue orange black unknown
//   runs N
// then N runs over the YUV cells in index order (Y major, then U, then V), each one byte of class
// (the position in the `classes` line) and the run length as an unsigned LEB128 varint; the runs
// cover exactly 2^(3 * bits) cells and nothing follows them. A box table is a few ten thousand
// runs (about 60 KB).
void writeColourLookup(std::ostream& out, const ColourTable& table);
// Throws std::runtime_error "NAME: reason" for a bad header, other bits, an unknown class, runs
// that do not cover the cells exactly, or trailing bytes.
ColourTable readColourLookup(std::istream& in, const std::string& name);
void writeColourLookupFile(const std::string& path, const ColourTable& table);
ColourTable readColourLookupFile(const std::string& path);

// Reads the `colours:` map of a colour preset: for each class name a list of boxes
// {y: [min, max], u: [min, max], v: [min, max]} (0..255, min <= max). Classes are tried in file
// order. Or, instead of `colours:`, `lookup_table: FILE.lut` (relative to the YAML's folder): a
// full lookup table. Throws config::Error with file:line for unknown classes, keys or bad
// ranges, both or neither of the two keys, and a lookup file that does not read.
ColourTable loadColourTable(const config::Node& root);
// Loads config/camera/<name>.yaml (or a path).
ColourTable loadColourTablePreset(const std::string& name_or_path);

}  // namespace fieldline::camera
