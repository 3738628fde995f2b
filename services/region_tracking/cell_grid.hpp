// The grid the tracker works on, and the homogeneity function that classifies one of its cells.
//
// A cell is a block of cell_size x cell_size pixels (1, 2, 4 or 8). The tracker never converts a
// whole frame: it asks a CellClassifier for the colour class of a cell when a drop reaches it.
// Class ids are small integers chosen by the caller (the camera's colour classes, or anything in
// a synthetic test); kNoClass is reserved for "nothing / not visited".
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <vector>

namespace fieldline::region_tracking {

using ClassId = std::uint8_t;
inline constexpr ClassId kNoClass = 0xFF;

// Size of the cell grid and how it maps to pixels.
struct CellGrid {
  int width = 0;      // cells per row
  int height = 0;     // rows of cells
  int cell_size = 1;  // pixels per cell side

  int cellCount() const { return width * height; }
  bool contains(int x, int y) const { return x >= 0 && y >= 0 && x < width && y < height; }
  int index(int x, int y) const { return y * width + x; }

  // The grid covering an image; a partial block at the right or bottom edge is left out.
  static CellGrid forImage(int imageWidth, int imageHeight, int cell_size) {
    if (cell_size != 1 && cell_size != 2 && cell_size != 4 && cell_size != 8) {
      throw std::invalid_argument("cell size must be 1, 2, 4 or 8 pixels");
    }
    if (imageWidth < cell_size || imageHeight < cell_size) {
      throw std::invalid_argument("image smaller than one cell");
    }
    return CellGrid{imageWidth / cell_size, imageHeight / cell_size, cell_size};
  }
};

// The homogeneity function: the colour class of cell (x, y) of the current frame. Two cells are
// homogeneous when they have the same class. Called only for cells inside the grid.
class CellClassifier {
 public:
  virtual ~CellClassifier() = default;
  virtual ClassId classify(int x, int y) const = 0;
  // Cells (first_x .. first_x + out.size() - 1, y), for the full-frame baselines; override when a
  // run of cells can be done faster than one by one.
  virtual void classifyRow(int y, int first_x, std::span<ClassId> out) const {
    for (std::size_t i = 0; i < out.size(); ++i)
      out[i] = classify(first_x + static_cast<int>(i), y);
  }
};

// A classifier over a precomputed class map (one ClassId per cell, row-major): for synthetic
// grids in tests, and for replaying a segmentation.
class ClassMapClassifier final : public CellClassifier {
 public:
  ClassMapClassifier(const std::vector<ClassId>& classes, int width)
      : classes_(classes), width_(width) {}
  ClassId classify(int x, int y) const override { return classes_[y * width_ + x]; }
  void classifyRow(int y, int first_x, std::span<ClassId> out) const override {
    const ClassId* row = classes_.data() + static_cast<std::size_t>(y) * width_ + first_x;
    std::copy(row, row + out.size(), out.begin());
  }

 private:
  const std::vector<ClassId>& classes_;
  int width_;
};

}  // namespace fieldline::region_tracking
