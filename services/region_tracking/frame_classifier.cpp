#include "services/region_tracking/frame_classifier.hpp"

#include <algorithm>
#include <cmath>

namespace fieldline::region_tracking {

FrameCellClassifier::FrameCellClassifier(const camera::ColourTable& table, int cellSize,
                                         const BlockClassifierParams& params)
    : table_(table), cellSize_(cellSize) {
  for (const BlockClaim& claim : params.claims) {
    const int pixels = static_cast<int>(std::ceil(claim.minFraction * cellSize * cellSize));
    claims_.push_back({classIdOf(claim.colour), std::max(1, pixels)});
  }
}

ClassId FrameCellClassifier::classify(int x, int y) const {
  if (cellSize_ == 1) return classIdOf(table_.classifyPixel(frame_, x, y));
  std::array<int, camera::kColourClassCount> votes{};
  const int u0 = x * cellSize_;
  const int v0 = y * cellSize_;
  // Most cells hold one class only: noticing that spares the claims and the majority search.
  camera::ColourClass first = camera::ColourClass::kUnknown;
  bool mixed = false;
  auto vote = [&](camera::ColourClass c, bool isFirst) {
    if (isFirst) first = c;
    mixed |= c != first;
    ++votes[static_cast<std::size_t>(c)];
  };
  if (frame_.format == camera::PixelFormat::kYuyv) {
    // Cells start at even columns (sizes 2, 4, 8): each row of a cell is whole Y0 U Y1 V pairs.
    for (int v = v0; v < v0 + cellSize_; ++v) {
      const std::uint8_t* pair =
          frame_.data + static_cast<std::ptrdiff_t>(v) * frame_.stride + 2 * u0;
      for (int k = 0; k < cellSize_ / 2; ++k, pair += 4) {
        vote(table_.classifyYuv(pair[0], pair[1], pair[3]), v == v0 && k == 0);
        vote(table_.classifyYuv(pair[2], pair[1], pair[3]), false);
      }
    }
  } else {
    for (int v = v0; v < v0 + cellSize_; ++v) {
      for (int u = u0; u < u0 + cellSize_; ++u) {
        vote(table_.classifyPixel(frame_, u, v), v == v0 && u == u0);
      }
    }
  }
  if (!mixed) return classIdOf(first);
  for (const Claim& claim : claims_) {
    if (votes[claim.classId] >= claim.minPixels) return claim.classId;
  }
  return static_cast<ClassId>(std::max_element(votes.begin(), votes.end()) - votes.begin());
}

std::vector<std::uint8_t> dontTouchCells(const camera::MirrorModel& mirror, const CellGrid& grid) {
  std::vector<std::uint8_t> mask(grid.cellCount(), 0);
  const int last = grid.cellSize - 1;
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      const int u = x * grid.cellSize;
      const int v = y * grid.cellSize;
      mask[grid.index(x, y)] = mirror.dontTouch(u, v) || mirror.dontTouch(u + last, v) ||
                               mirror.dontTouch(u, v + last) ||
                               mirror.dontTouch(u + last, v + last);
    }
  }
  return mask;
}

}  // namespace fieldline::region_tracking
