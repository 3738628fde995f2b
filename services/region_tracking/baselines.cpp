#include "services/region_tracking/baselines.hpp"

#include <algorithm>
#include <array>
#include <numeric>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace fieldline::region_tracking {

FullFrameClassMap::FullFrameClassMap(const CellGrid& grid, std::span<const std::uint8_t> dontTouch,
                                     FullFramePolicy policy)
    : grid_(grid), policy_(policy), classes_(grid.cellCount(), kNoClass) {
  if (!dontTouch.empty() && static_cast<int>(dontTouch.size()) != grid.cellCount()) {
    throw std::invalid_argument("full-frame segmentation: don't-touch mask size mismatch");
  }
  for (int y = 0; y < grid.height; ++y) {
    auto allowed = [&](int x) { return dontTouch.empty() || !dontTouch[grid.index(x, y)]; };
    int x = 0;
    while (x < grid.width) {
      const int first = x;
      const bool allowedRun = allowed(x);
      while (x < grid.width && allowed(x) == allowedRun)
        ++x;
      (allowedRun ? allowed_spans_ : forbidden_spans_).push_back({y, first, x});
    }
  }
}

void FullFrameClassMap::classify(const CellClassifier& classifier) {
  if (policy_ == FullFramePolicy::kClassifyEveryCell) {
    for (int y = 0; y < grid_.height; ++y) {
      classifier.classifyRow(y, 0,
                             std::span<ClassId>(classes_).subspan(grid_.index(0, y), grid_.width));
    }
    for (const Span& span : forbidden_spans_) {
      std::fill_n(classes_.begin() + grid_.index(span.first_x, span.y), span.end_x - span.first_x,
                  kNoClass);
    }
    return;
  }
  for (const Span& span : allowed_spans_) {
    classifier.classifyRow(span.y, span.first_x,
                           std::span<ClassId>(classes_).subspan(grid_.index(span.first_x, span.y),
                                                                span.end_x - span.first_x));
  }
}

// ---------------------------------------------------------------------------------------------
// (a) CMVision-style

CmvisionSegmenter::CmvisionSegmenter(const CellGrid& grid, std::span<const ClassId> trackedClasses,
                                     std::span<const std::uint8_t> dontTouch,
                                     FullFramePolicy policy)
    : grid_(grid),
      layout_(grid),
      class_map_(grid, dontTouch, policy),
      tracked_classes_(trackedClasses.begin(), trackedClasses.end()),
      padded_(layout_.size(), kNoClass),
      row_start_(grid.height + 1, 0),
      boundary_cells_by_class_(trackedClasses.size()),
      connectivity_(grid) {
  if (trackedClasses.size() > 255) throw std::invalid_argument("cmvision: too many classes");
  for (std::size_t slot = 0; slot < trackedClasses.size(); ++slot) {
    const ClassId c = trackedClasses[slot];
    if (c == kNoClass) throw std::invalid_argument("cmvision: class id 255 is reserved");
    tracked_[c] = true;
    slot_of_[c] = static_cast<std::uint8_t>(slot);
  }
  runs_.reserve(grid.cellCount() / 2 + grid.height);
  run_region_.reserve(runs_.capacity());
  for (auto& cells : boundary_cells_by_class_)
    cells.reserve(grid.cellCount() / 2);
}

int CmvisionSegmenter::findRoot(int run) {
  int root = run;
  while (runs_[root].parent != root)
    root = runs_[root].parent;
  while (runs_[run].parent != root) {  // path compression
    const int next = runs_[run].parent;
    runs_[run].parent = root;
    run = next;
  }
  return root;
}

void CmvisionSegmenter::unite(int a, int b) {
  const int rootA = findRoot(a);
  const int rootB = findRoot(b);
  // The older run stays root, so roots are the first run of each region in scan order.
  if (rootA < rootB) {
    runs_[rootB].parent = rootA;
  } else if (rootB < rootA) {
    runs_[rootA].parent = rootB;
  }
}

void CmvisionSegmenter::segment(const CellClassifier& classifier) {
  class_map_.classify(classifier);
  const std::span<const ClassId> classes = class_map_.classes();

  // Run-length encoding of the tracked classes.
  runs_.clear();
  for (int y = 0; y < grid_.height; ++y) {
    row_start_[y] = static_cast<int>(runs_.size());
    const ClassId* row = classes.data() + static_cast<std::size_t>(y) * grid_.width;
    int x = 0;
    while (x < grid_.width) {
      const ClassId c = row[x];
      const int first = x;
      while (x < grid_.width && row[x] == c)
        ++x;
      if (tracked_[c]) {
        const int index = static_cast<int>(runs_.size());
        runs_.push_back({static_cast<std::int16_t>(y), static_cast<std::int16_t>(first),
                         static_cast<std::int16_t>(x), c, index});
      }
    }
  }
  row_start_[grid_.height] = static_cast<int>(runs_.size());

  // Union-find: join runs of the same class that share at least one column with a run of the
  // row above (4-connectivity).
  for (int y = 1; y < grid_.height; ++y) {
    int above = row_start_[y - 1];
    const int aboveEnd = row_start_[y];
    for (int run = row_start_[y]; run < row_start_[y + 1]; ++run) {
      const Run& current = runs_[run];
      while (above < aboveEnd && runs_[above].end_x <= current.first_x)
        ++above;
      for (int a = above; a < aboveEnd && runs_[a].first_x < current.end_x; ++a) {
        if (runs_[a].class_id == current.class_id) unite(run, a);
      }
    }
  }

  // Regions: one per root, with size and bounding box.
  regions_.clear();
  run_region_.resize(runs_.size());
  for (int run = 0; run < static_cast<int>(runs_.size()); ++run) {
    const int root = findRoot(run);
    const Run& r = runs_[run];
    if (root == run) {
      run_region_[run] = static_cast<int>(regions_.size());
      regions_.push_back({r.class_id, 0, r.first_x, r.y, r.end_x - 1, r.y});
    } else {
      run_region_[run] = run_region_[root];  // roots come first in scan order
    }
    Region& region = regions_[run_region_[run]];
    region.cells += r.end_x - r.first_x;
    region.min_x = std::min<int>(region.min_x, r.first_x);
    region.max_x = std::max<int>(region.max_x, r.end_x - 1);
    region.max_y = r.y;
  }

  markBoundaries();
  contours_.clear();
  for (std::size_t slot = 0; slot < tracked_classes_.size(); ++slot) {
    connectivity_.extractContoursAt(boundary_cells_by_class_[slot], tracked_classes_[slot],
                                    contours_);
  }
}

// Every side of a tracked cell facing another class (or the grid's edge) is a boundary side.
// Runs are maximal, so the left side of a run's first cell and the right side of its last cell
// always are; inside a run only the rows above and below need comparing. The boundary cells of
// each class are listed in scan order, as comparing every cell with its four neighbours would
// list them, so the contours come out identical (same contours, same order, same start points).
void CmvisionSegmenter::markBoundaries() {
  for (auto& cells : boundary_cells_by_class_)
    cells.clear();
  for (int y = 0; y < grid_.height; ++y) {
    const ClassId* source = class_map_.classes().data() + static_cast<std::size_t>(y) * grid_.width;
    std::copy(source, source + grid_.width, padded_.begin() + layout_.index(0, y));
  }
  const int stride = layout_.width;
  for (const Run& r : runs_) {
    std::vector<std::int32_t>& cells = boundary_cells_by_class_[slot_of_[r.class_id]];
    const int first = layout_.index(r.first_x, r.y);
    const int last = first + (r.end_x - r.first_x) - 1;
    const ClassId c = r.class_id;
    const ClassId* map = padded_.data();
    for (int cell = first; cell <= last; ++cell) {
      const unsigned sides = (map[cell - stride] != c ? 1u : 0u) | (cell == last ? 2u : 0u) |
                             (map[cell + stride] != c ? 4u : 0u) | (cell == first ? 8u : 0u);
      if (sides != 0) {
        connectivity_.addBoundarySidesAt(cell, sides);
        cells.push_back(cell);
      }
    }
  }
}

void CmvisionSegmenter::labelCells(std::vector<int>& labels) const {
  labels.assign(grid_.cellCount(), -1);
  for (std::size_t run = 0; run < runs_.size(); ++run) {
    const Run& r = runs_[run];
    std::fill_n(labels.begin() + grid_.index(r.first_x, r.y), r.end_x - r.first_x,
                run_region_[run]);
  }
}

// ---------------------------------------------------------------------------------------------
// (b) OpenCV

OpenCvSegmenter::OpenCvSegmenter(const CellGrid& grid, std::span<const ClassId> trackedClasses,
                                 std::span<const std::uint8_t> dontTouch, FullFramePolicy policy,
                                 AbsentClasses absent)
    : grid_(grid),
      class_map_(grid, dontTouch, policy),
      tracked_classes_(trackedClasses.begin(), trackedClasses.end()),
      absent_(absent),
      mask_(grid.height, grid.width, CV_8U) {}

void OpenCvSegmenter::segment(const CellClassifier& classifier) {
  class_map_.classify(classifier);
  // A Mat header over the class map; no copy.
  const cv::Mat classes(grid_.height, grid_.width, CV_8U,
                        const_cast<ClassId*>(class_map_.classes().data()));
  regions_.clear();
  contours_.clear();
  // Which classes the frame has: labelling an empty mask finds nothing, at full cost.
  std::array<int, 256> histogram{};
  if (absent_ == AbsentClasses::kSkip) {
    for (const ClassId c : class_map_.classes())
      ++histogram[c];
  }
  const int half = grid_.cell_size / 2;
  for (const ClassId c : tracked_classes_) {
    if (absent_ == AbsentClasses::kSkip && histogram[c] == 0) continue;
    cv::compare(classes, cv::Scalar(c), mask_, cv::CMP_EQ);
    const int labels =
        cv::connectedComponentsWithStats(mask_, labels_, stats_, centroids_, 4, CV_32S);
    for (int label = 1; label < labels; ++label) {
      const int* s = stats_.ptr<int>(label);
      regions_.push_back({c, s[cv::CC_STAT_AREA], s[cv::CC_STAT_LEFT], s[cv::CC_STAT_TOP],
                          s[cv::CC_STAT_LEFT] + s[cv::CC_STAT_WIDTH] - 1,
                          s[cv::CC_STAT_TOP] + s[cv::CC_STAT_HEIGHT] - 1});
    }
    cv::findContours(mask_, cv_contours_, hierarchy_, cv::RETR_CCOMP, cv::CHAIN_APPROX_NONE);
    for (std::size_t i = 0; i < cv_contours_.size(); ++i) {
      Contour contour;
      contour.class_id = c;
      contour.outer = hierarchy_[i][3] < 0;  // RETR_CCOMP: holes have a parent
      contour.begin = static_cast<int>(contours_.points.size());
      for (const cv::Point& p : cv_contours_[i]) {
        contours_.points.push_back({p.x * grid_.cell_size + half, p.y * grid_.cell_size + half});
      }
      contour.end = static_cast<int>(contours_.points.size());
      const double area = cv::contourArea(cv_contours_[i], true);
      contour.signed_cell_area = static_cast<int>(contour.outer ? std::abs(area) : -std::abs(area));
      contours_.contours.push_back(contour);
    }
  }
}

// ---------------------------------------------------------------------------------------------

Agreement compareWithFullSegmentation(std::span<const ClassId> trackerVisited,
                                      const CmvisionSegmenter& full) {
  Agreement agreement;
  std::vector<int> labels;
  full.labelCells(labels);
  const std::span<const Region> regions = full.regions();
  const std::span<const ClassId> classes = full.classMap();
  std::vector<int> trackedCells(regions.size(), 0);
  for (std::size_t i = 0; i < trackerVisited.size(); ++i) {
    const ClassId owner = trackerVisited[i];
    if (owner == kNoClass) continue;
    if (classes[i] != owner) {
      ++agreement.stale_cells;
    } else if (labels[i] >= 0) {
      ++trackedCells[labels[i]];
    }
  }
  for (std::size_t r = 0; r < regions.size(); ++r) {
    if (trackedCells[r] == regions[r].cells) {
      ++agreement.regions_tracked;
    } else if (trackedCells[r] == 0) {
      ++agreement.regions_untracked;
    } else {
      ++agreement.regions_partial;
    }
  }
  return agreement;
}

}  // namespace fieldline::region_tracking
