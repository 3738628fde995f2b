// The homogeneity function on a real frame: the colour class of a block of pixels, read from the
// raw frame in place through the colour table (no conversion of the frame).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "common/camera/colour.hpp"
#include "common/camera/frame.hpp"
#include "common/camera/mirror_model.hpp"
#include "services/region_tracking/cell_grid.hpp"
#include "services/region_tracking/class_lookup.hpp"

namespace fieldline::region_tracking {

inline ClassId classIdOf(camera::ColourClass colour) {
  return static_cast<ClassId>(colour);
}

// A class that claims a block before the majority vote when at least `min_fraction` of its
// pixels have it. Thin structures need this: a 2 px field line in 4x4 blocks never wins a
// majority, and the green regions on both sides of it would merge into one.
struct BlockClaim {
  camera::ColourClass colour = camera::ColourClass::kWhite;
  double min_fraction = 0.125;
};

struct BlockClassifierParams {
  // Tried in order; the first class reaching its fraction wins. Otherwise the most frequent
  // class of the block (ties to the lower class number).
  std::vector<BlockClaim> claims = {{camera::ColourClass::kOrange, 0.125},
                                    {camera::ColourClass::kWhite, 0.125}};
};

class FrameCellClassifier final : public CellClassifier {
 public:
  FrameCellClassifier(const camera::ColourTable& table, int cell_size,
                      const BlockClassifierParams& params = {});
  // YUYV frames classified with `lookup` (the classes of `table`; it must outlive this).
  FrameCellClassifier(const camera::ColourTable& table, const ClassLookup& lookup, int cell_size,
                      const BlockClassifierParams& params = {});

  // The frame the next classify() calls read; it must outlive them (FrameProcessor::process
  // sets it for the call and clears it at the end).
  void setFrame(const camera::FrameView& frame) { frame_ = frame; }

  ClassId classify(int x, int y) const override;
  // The same for a run of cells of one row, without a virtual call per cell (the full-frame
  // baselines classify whole rows).
  void classifyRow(int y, int first_x, std::span<ClassId> out) const override;

 private:
  struct Claim {
    ClassId class_id;
    int min_pixels;
  };
  template <int kSize>
  ClassId classifyYuyvBlock(int x, int y) const;
  ClassId classifyBgrBlock(int x, int y) const;
  // The class of a block from its votes (8 bits per class), its pixel count and the class of
  // its first pixel.
  ClassId decide(std::uint64_t votes, int pixels, ClassId first) const;
  ClassId classifyBlock(int x, int y) const;
  FrameCellClassifier(const camera::ColourTable& table, std::shared_ptr<const ClassLookup> lookup,
                      int cell_size, const BlockClassifierParams& params);
  const camera::ColourTable& table_;
  std::shared_ptr<const ClassLookup> lookup_;  // owned when made from the table alone
  int cell_size_;
  std::vector<Claim> claims_;
  camera::FrameView frame_;
};

// The don't-touch mask of the cell grid: a cell is forbidden unless its four corner pixels all
// see usable floor (outside the robot's own reflection, inside the useful radius).
std::vector<std::uint8_t> dontTouchCells(const camera::MirrorModel& mirror, const CellGrid& grid);

}  // namespace fieldline::region_tracking
