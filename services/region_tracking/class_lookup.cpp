#include "services/region_tracking/class_lookup.hpp"

#include <algorithm>

namespace fieldline::region_tracking {

ClassLookup::ClassLookup(const ClassLookup& other) {
  *this = other;
}

ClassLookup& ClassLookup::operator=(const ClassLookup& other) {
  if (this == &other) return *this;
  storage_.assign(other.storage_.size(), camera::ColourClass::kUnknown);
  if (!storage_.empty()) {
    std::copy_n(other.data(), camera::ColourTable::kCells, aligned(storage_.data()));
  }
  return *this;
}

void ClassLookup::rebuild(const camera::ColourTable& table) {
  storage_.assign(camera::ColourTable::kCells + 63, camera::ColourClass::kUnknown);
  camera::ColourClass* cells = aligned(storage_.data());
  // Every cell at its lowest level: the table quantises by the same 2 bits.
  for (unsigned y = 0; y < 256; y += 4) {
    for (unsigned u = 0; u < 256; u += 4) {
      for (unsigned v = 0; v < 256; v += 4) {
        const auto cy = static_cast<std::uint8_t>(y), cu = static_cast<std::uint8_t>(u),
                   cv = static_cast<std::uint8_t>(v);
        cells[yPart(cy) | uvPart(cu, cv)] = table.classifyYuv(cy, cu, cv);
      }
    }
  }
}

}  // namespace fieldline::region_tracking
