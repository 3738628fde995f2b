// The colour table's YUV classes in another order: blocks of 4x4x4 of its cells (Y, U and V), one
// block to a cache line.
//
// The colour table (common/camera/colour.hpp) keeps V innermost: the 64 V cells of one (Y, U)
// fill a cache line, so the pixels of one colour with the camera's noise (a few cells of Y and U
// either way) spread over some 10 lines per colour, and a frame's pixels over 400-odd lines of the
// 256 KiB table. In the running team every one of them is a miss to memory on each frame (the
// other processes take the cache between two frames), and the cell classifier's lookups were the
// largest single cold cost of a frame (issue 32, docs/performance.md). In blocks the same pixels
// touch about a quarter of the lines. The classes are the table's, cell for cell.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "common/camera/colour.hpp"

namespace fieldline::region_tracking {

namespace class_lookup_detail {
// The line (bits 6-17: Y, U, V's upper 4 bits) and the place in it (bits 0-5: their next 2).
struct Parts {
  std::array<std::uint32_t, 256> y, u, v;
};
constexpr Parts makeParts() {
  Parts p{};
  for (std::uint32_t c = 0; c < 256; ++c) {
    p.y[c] = ((c >> 4) << 14) | (((c >> 2) & 3u) << 4);
    p.u[c] = ((c >> 4) << 10) | (((c >> 2) & 3u) << 2);
    p.v[c] = ((c >> 4) << 6) | ((c >> 2) & 3u);
  }
  return p;
}
inline constexpr Parts kParts = makeParts();
}  // namespace class_lookup_detail

class ClassLookup {
 public:
  explicit ClassLookup(const camera::ColourTable& table) { rebuild(table); }
  // A copy's storage may start elsewhere in a cache line: the cells are copied to its own
  // aligned start (a moved storage keeps its place).
  ClassLookup(const ClassLookup& other);
  ClassLookup& operator=(const ClassLookup& other);
  ClassLookup(ClassLookup&&) = default;
  ClassLookup& operator=(ClassLookup&&) = default;
  // The classes of `table` (after it changed).
  void rebuild(const camera::ColourTable& table);

  camera::ColourClass classifyYuv(std::uint8_t y, std::uint8_t u, std::uint8_t v) const {
    return data()[yPart(y) | uvPart(u, v)];
  }
  // The index of (Y, U, V) in data() is yPart(Y) | uvPart(U, V): the hot loops take the pair's
  // U and V part once for both of its pixels. Each channel's bits from a table of 256 (3 KiB in
  // all): a load each, where shifting and masking the two halves of the index took 5 operations.
  static std::uint32_t yPart(std::uint8_t y) { return class_lookup_detail::kParts.y[y]; }
  static std::uint32_t uvPart(std::uint8_t u, std::uint8_t v) {
    return class_lookup_detail::kParts.u[u] | class_lookup_detail::kParts.v[v];
  }
  // The cells, the first at a cache line's start (a block is one line).
  const camera::ColourClass* data() const { return aligned(storage_.data()); }

 private:
  template <typename T>
  static T* aligned(T* p) {
    const auto misalignment = reinterpret_cast<std::uintptr_t>(p) & 63u;
    return p + ((64u - misalignment) & 63u);
  }
  static_assert(camera::ColourTable::kIndexBits == 6, "4x4x4 blocks of 64 levels per channel");
  // kCells and room to start at a line.
  std::vector<camera::ColourClass> storage_;
};

}  // namespace fieldline::region_tracking
