// Full-frame segmentations to measure the tracker against. Both classify every cell of every
// frame and return the same kind of output as the tracker: the regions of the tracked classes
// and their closed boundary contours. Don't-touch cells are left out of the regions; whether
// they are classified at all is a choice (FullFramePolicy): CMVision classifies every pixel,
// a baseline that knows the mask can skip them.
//   (a) CmvisionSegmenter: CMVision-style, written here: class map, run-length encoding,
//       union-find over runs of neighbouring rows, boundaries on the connectivity grid. The
//       boundaries are marked from the runs over a class map padded by one cell: a run's two
//       ends are boundary sides by construction, so only the up and down sides are compared.
//   (b) OpenCvSegmenter: a histogram of the class map, then for each tracked class present in
//       the frame a mask, cv::connectedComponentsWithStats, cv::findContours.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <opencv2/core.hpp>

#include "services/region_tracking/cell_grid.hpp"
#include "services/region_tracking/contours.hpp"

namespace fieldline::region_tracking {

// A connected region found by a baseline.
struct Region {
  ClassId class_id = kNoClass;
  int cells = 0;
  // Bounding box in cells, inclusive.
  int min_x = 0, min_y = 0, max_x = 0, max_y = 0;
};

enum class FullFramePolicy {
  // Classify every cell, then drop the don't-touch ones from the class map (CMVision).
  kClassifyEveryCell,
  // Read only the cells outside the don't-touch mask.
  kSkipDontTouch,
};

// The classified cells of a whole frame; don't-touch cells are kNoClass in the map.
class FullFrameClassMap {
 public:
  FullFrameClassMap(const CellGrid& grid, std::span<const std::uint8_t> dontTouch,
                    FullFramePolicy policy);
  void classify(const CellClassifier& classifier);
  const CellGrid& grid() const { return grid_; }
  std::span<const ClassId> classes() const { return classes_; }
  ClassId at(int x, int y) const { return classes_[grid_.index(x, y)]; }

 private:
  struct Span {
    int y, first_x, end_x;
  };
  CellGrid grid_;
  FullFramePolicy policy_;
  std::vector<Span> allowed_spans_;  // maximal runs of touchable cells per row
  std::vector<Span> forbidden_spans_;
  std::vector<ClassId> classes_;
};

class CmvisionSegmenter {
 public:
  CmvisionSegmenter(const CellGrid& grid, std::span<const ClassId> trackedClasses,
                    std::span<const std::uint8_t> dontTouch = {},
                    FullFramePolicy policy = FullFramePolicy::kClassifyEveryCell);

  void segment(const CellClassifier& classifier);

  std::span<const ClassId> classMap() const { return class_map_.classes(); }
  std::span<const Region> regions() const { return regions_; }
  const ContourSet& contours() const { return contours_; }
  // Region index of every cell (-1 for cells of untracked classes); computed on request, for
  // comparisons outside the timed path.
  void labelCells(std::vector<int>& labels) const;

 private:
  struct Run {
    std::int16_t y, first_x, end_x;
    ClassId class_id;
    int parent;  // union-find parent (a run index); the root's region index after labelling
  };
  int findRoot(int run);
  void unite(int a, int b);
  void markBoundaries();

  CellGrid grid_;
  PaddedLayout layout_;
  FullFrameClassMap class_map_;
  bool tracked_[256] = {};
  std::uint8_t slot_of_[256] = {};  // index into tracked_classes_ by class id
  std::vector<ClassId> tracked_classes_;
  // The class map with a frame of kNoClass around it (PaddedLayout), so every cell of a run has
  // an up and a down neighbour to compare with.
  std::vector<ClassId> padded_;
  std::vector<Run> runs_;
  std::vector<int> row_start_;  // first run of each row, plus one past the last
  std::vector<int> run_region_;
  std::vector<Region> regions_;
  std::vector<std::vector<std::int32_t>> boundary_cells_by_class_;  // padded indices
  ConnectivityGrid connectivity_;
  ContourSet contours_;
};

// Whether (b) labels a tracked class that has no cell in the frame (an empty mask gives no
// regions and no contours either way; skipping only saves the work).
enum class AbsentClasses {
  kSkip,
  kLabel,
};

class OpenCvSegmenter {
 public:
  OpenCvSegmenter(const CellGrid& grid, std::span<const ClassId> trackedClasses,
                  std::span<const std::uint8_t> dontTouch = {},
                  FullFramePolicy policy = FullFramePolicy::kClassifyEveryCell,
                  AbsentClasses absent = AbsentClasses::kSkip);

  void segment(const CellClassifier& classifier);

  std::span<const ClassId> classMap() const { return class_map_.classes(); }
  std::span<const Region> regions() const { return regions_; }
  // Contour points are the centres of the boundary cells, in pixels (OpenCV's convention).
  const ContourSet& contours() const { return contours_; }

 private:
  CellGrid grid_;
  FullFrameClassMap class_map_;
  std::vector<ClassId> tracked_classes_;
  AbsentClasses absent_;
  cv::Mat mask_, labels_, stats_, centroids_;
  std::vector<std::vector<cv::Point>> cv_contours_;
  std::vector<cv::Vec4i> hierarchy_;
  std::vector<Region> regions_;
  ContourSet contours_;
};

// How the tracker's regions compare with a full segmentation of the same frame.
struct Agreement {
  // Full-segmentation regions of the tracked classes: entirely tracked, partly tracked (a
  // disagreement), not tracked at all (never seeded or lost).
  int regions_tracked = 0;
  int regions_partial = 0;
  int regions_untracked = 0;
  // Tracked cells whose class in the frame is a different one (a region that jumped away
  // without overlap, leaving its old cells behind).
  int stale_cells = 0;
  bool exact() const { return regions_partial == 0 && stale_cells == 0; }
};
Agreement compareWithFullSegmentation(std::span<const ClassId> trackerVisited,
                                      const CmvisionSegmenter& full);

}  // namespace fieldline::region_tracking
