#include "services/region_tracking/frame_classifier.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace fieldline::region_tracking {

FrameCellClassifier::FrameCellClassifier(const camera::ColourTable& table, int cell_size,
                                         const BlockClassifierParams& params)
    : FrameCellClassifier(table, std::make_shared<const ClassLookup>(table), cell_size, params) {}

FrameCellClassifier::FrameCellClassifier(const camera::ColourTable& table,
                                         const ClassLookup& lookup, int cell_size,
                                         const BlockClassifierParams& params)
    // Not owned: the aliasing constructor with no owner.
    : FrameCellClassifier(
          table, std::shared_ptr<const ClassLookup>(std::shared_ptr<const ClassLookup>(), &lookup),
          cell_size, params) {}

FrameCellClassifier::FrameCellClassifier(const camera::ColourTable& table,
                                         std::shared_ptr<const ClassLookup> lookup, int cell_size,
                                         const BlockClassifierParams& params)
    : table_(table), lookup_(std::move(lookup)), cell_size_(cell_size) {
  if (cell_size != 1 && cell_size != 2 && cell_size != 4 && cell_size != 8) {
    throw std::invalid_argument("block classifier: cell size must be 1, 2, 4 or 8 pixels");
  }
  for (const BlockClaim& claim : params.claims) {
    const int pixels = static_cast<int>(std::ceil(claim.min_fraction * cell_size * cell_size));
    claims_.push_back({classIdOf(claim.colour), std::max(1, pixels)});
  }
}

// Votes are counted in one 64-bit word, 8 bits per class (a cell has at most 64 pixels): adding
// to a register instead of an array in memory keeps the count of a mixed cell off the
// store-to-load path. Two words, for even and odd pixels, halve the dependency chain.
static_assert(camera::kColourClassCount <= 8, "one byte of the vote word per class");

namespace {
inline std::uint64_t voteFor(camera::ColourClass c) {
  return std::uint64_t{1} << (8 * static_cast<unsigned>(c));
}
inline int votesOf(std::uint64_t votes, unsigned class_id) {
  return static_cast<int>((votes >> (8 * class_id)) & 0xFF);
}
}  // namespace

ClassId FrameCellClassifier::decide(std::uint64_t votes, int pixels, ClassId first) const {
  // Most cells hold one class only: then there is nothing to vote on.
  if (votes == static_cast<std::uint64_t>(pixels) << (8 * first)) return first;
  for (const Claim& claim : claims_) {
    if (votesOf(votes, claim.class_id) >= claim.min_pixels) return claim.class_id;
  }
  // The most frequent class; ties go to the lower class number.
  unsigned best = 0;
  for (unsigned c = 1; c < camera::kColourClassCount; ++c) {
    if (votesOf(votes, c) > votesOf(votes, best)) best = c;
  }
  return static_cast<ClassId>(best);
}

template <int kSize>
ClassId FrameCellClassifier::classifyYuyvBlock(int x, int y) const {
  // Cells start at even columns (sizes 2, 4, 8): each row of a cell is whole Y0 U Y1 V pairs.
  const std::uint8_t* row =
      frame_.data + static_cast<std::ptrdiff_t>(y) * kSize * frame_.stride + 2 * kSize * x;
  // The table's classes in blocks of cells (class_lookup.hpp): fewer cache lines a frame.
  const camera::ColourClass* classes = lookup_->data();
  const camera::ColourClass first =
      classes[ClassLookup::yPart(row[0]) | ClassLookup::uvPart(row[1], row[3])];
  std::uint64_t evenVotes = 0, oddVotes = 0;
  for (int v = 0; v < kSize; ++v, row += frame_.stride) {
    const std::uint8_t* pair = row;
    for (int k = 0; k < kSize / 2; ++k, pair += 4) {
      const std::uint32_t uv = ClassLookup::uvPart(pair[1], pair[3]);
      evenVotes += voteFor(classes[ClassLookup::yPart(pair[0]) | uv]);
      oddVotes += voteFor(classes[ClassLookup::yPart(pair[2]) | uv]);
    }
  }
  return decide(evenVotes + oddVotes, kSize * kSize, classIdOf(first));
}

ClassId FrameCellClassifier::classifyBgrBlock(int x, int y) const {
  const int u0 = x * cell_size_;
  const int v0 = y * cell_size_;
  std::uint64_t votes = 0;
  for (int v = v0; v < v0 + cell_size_; ++v) {
    for (int u = u0; u < u0 + cell_size_; ++u)
      votes += voteFor(table_.classifyPixel(frame_, u, v));
  }
  return decide(votes, cell_size_ * cell_size_, classIdOf(table_.classifyPixel(frame_, u0, v0)));
}

inline ClassId FrameCellClassifier::classifyBlock(int x, int y) const {
  if (cell_size_ == 1) return classIdOf(table_.classifyPixel(frame_, x, y));
  if (frame_.format != camera::PixelFormat::kYuyv) return classifyBgrBlock(x, y);
  switch (cell_size_) {
    case 2:
      return classifyYuyvBlock<2>(x, y);
    case 4:
      return classifyYuyvBlock<4>(x, y);
    default:
      return classifyYuyvBlock<8>(x, y);
  }
}

ClassId FrameCellClassifier::classify(int x, int y) const {
  return classifyBlock(x, y);
}

void FrameCellClassifier::classifyRow(int y, int first_x, std::span<ClassId> out) const {
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = classifyBlock(first_x + static_cast<int>(i), y);
}

std::vector<std::uint8_t> dontTouchCells(const camera::MirrorModel& mirror, const CellGrid& grid) {
  std::vector<std::uint8_t> mask(grid.cellCount(), 0);
  const int last = grid.cell_size - 1;
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      const int u = x * grid.cell_size;
      const int v = y * grid.cell_size;
      mask[grid.index(x, y)] = mirror.dontTouch(u, v) || mirror.dontTouch(u + last, v) ||
                               mirror.dontTouch(u, v + last) ||
                               mirror.dontTouch(u + last, v + last);
    }
  }
  return mask;
}

}  // namespace fieldline::region_tracking
