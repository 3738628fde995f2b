// Tracking homogeneous colour regions from frame to frame by shrinking and growing (seed ch. 3).
//
// The idea in one paragraph. A region is a 4-connected set of cells of one colour class, marked
// in the visited array V. Its boundary cells are kept as "drops". When a new frame arrives:
//   shrink (procedure 2): drops whose cell no longer has the class give up their cell and spread
//     into the region's still-marked neighbours, unmarking them; drops whose cell still has the
//     class stop. The region shrinks to its overlap with the new image; the stopped drops seed:
//   grow (procedure 1): drops spread to unvisited neighbours that have the class, marking them,
//     until the region fills its new extent. Every drop that saw a non-region neighbour is a
//     boundary drop again, and the sides it saw go into the connectivity grid.
// Only cells that changed, plus a band along the boundaries, are ever classified: that is the
// whole gain over classifying every cell of every frame. A region that jumps without overlapping
// its old position is lost; the class is then searched for in the whole frame (initial search).
//
// Several classes are tracked at once, each with its own pair of drop queues, sharing V (which
// holds the class of the region owning a cell). All classes shrink before any class grows, so a
// class never grows into a cell another class still holds from the previous frame.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "services/region_tracking/cell_grid.hpp"
#include "services/region_tracking/contours.hpp"

namespace fieldline::config {
class Node;
}

namespace fieldline::region_tracking {

// How one colour class is tracked.
struct ClassTracking {
  ClassId classId = 0;
  // When the class has no region left, search the whole frame for its largest regions (seed
  // 3.1.7). Costs a full pass over the frame in every frame the class stays absent.
  bool searchWhenLost = true;
  // At most this many regions are seeded by one initial search (the seed uses 10).
  int maxSeedRegions = 10;
  // Regions smaller than this (cells) are not seeded by an initial search.
  int minSeedCells = 4;
  // Extension to the seed: every frame, unvisited cells of this class next to the boundary of
  // the regions of class `seedFromBoundaryOf` become seeds (e.g. the ball next to green). The
  // parent must come earlier in the class list. kNoClass: off.
  ClassId seedFromBoundaryOf = kNoClass;
};

struct TrackerConfig {
  // Pixels per cell side: 1, 2, 4 or 8.
  int cellSize = 4;
  // Classes in processing order; class ids must be distinct and not kNoClass.
  std::vector<ClassTracking> classes;
  // Forget everything and search again every this many frames (0: never; the seed uses 300).
  int reinitialisePeriodFrames = 300;
};

// Reads keys cell_size, reinitialise_period_frames and a list `classes` of maps {class_id,
// search_when_lost, max_seed_regions, min_seed_cells, seed_from_boundary_of}.
TrackerConfig loadTrackerConfig(const config::Node& node);

// What one track() call did: the quantities of the seed's table 3.1.
struct TrackingStats {
  std::int64_t frame = 0;
  // Distinct cells whose class was computed in this frame (each at most once).
  int cellsClassified = 0;
  // cellsClassified / cells in the grid: the fraction of the image accessed.
  double touchedFraction = 0.0;
  // Drops taken from the queues by shrink and grow together.
  int dropsProcessed = 0;
  // Cells of all tracked regions at the end of the previous frame, after shrinking to the new
  // frame (the overlap), and after growing.
  int cellsBefore = 0;
  int cellsAfterShrink = 0;
  int cellsAfterGrow = 0;
  // cellsAfterShrink / cellsAfterGrow: the share of this frame's regions carried over (1 when
  // nothing moved, 0 after an initial search).
  double overlap = 0.0;
  // Classes that had to be searched for in the whole frame.
  int initialSearches = 0;
  bool reinitialised = false;
  int contours = 0;
};

class RegionTracker {
 public:
  // `dontTouch`: one byte per cell, nonzero where the tracker must not go (e.g. outside the
  // mirror); empty means everywhere allowed. Throws std::invalid_argument on a bad config.
  RegionTracker(const CellGrid& grid, const TrackerConfig& config,
                std::vector<std::uint8_t> dontTouch = {});

  // Tracks all classes into the frame `classifier` looks at, then extracts the boundaries.
  const TrackingStats& track(const CellClassifier& classifier);

  // Stops tracking the region of `classId` containing cell (x, y) (shrinking without a stopping
  // criterion). Returns the number of cells released; 0 if the cell is not in such a region.
  int dropRegion(ClassId classId, int x, int y);
  // Stops tracking every region of a class.
  void dropClass(ClassId classId);
  // Adds a seed cell for a class, grown on the next track() if the cell then has the class.
  void addSeed(ClassId classId, int x, int y);
  // Forgets all regions; the next track() starts from initial searches.
  void reinitialise();

  const CellGrid& grid() const { return grid_; }
  const TrackerConfig& config() const { return config_; }
  // The class owning each cell (kNoClass where no tracked region is), row-major.
  std::span<const ClassId> visited() const { return visited_; }
  // Boundaries of all tracked regions after the last track().
  const ContourSet& contours() const { return contours_; }
  // Boundary cells of a class's regions after the last track().
  std::span<const Cell> boundaryCells(ClassId classId) const;
  // Cells of a class's regions after the last track().
  int regionCells(ClassId classId) const;
  const TrackingStats& stats() const { return stats_; }

 private:
  // Per class: the pair of drop queues (used as stacks; order does not matter) and its size.
  struct ClassState {
    ClassTracking tracking;
    std::vector<Cell> growDrops;    // Q: drops still to spread during grow
    std::vector<Cell> shrinkDrops;  // Q': boundary drops, the start of the next shrink
    std::vector<Cell> pendingSeeds;
    int cells = 0;
  };

  ClassId classOf(int x, int y);
  bool blocked(int x, int y) const { return !grid_.contains(x, y) || dontTouch_[grid_.index(x, y)]; }
  ClassState* stateOf(ClassId classId);

  void shrink(ClassState& state);
  void grow(ClassState& state);
  void seedFromBoundary(ClassState& state, const ClassState& parent);
  void seedPending(ClassState& state);
  bool initialSearch(ClassState& state);

  CellGrid grid_;
  TrackerConfig config_;
  std::vector<std::uint8_t> dontTouch_;
  std::vector<ClassId> visited_;  // V
  std::vector<ClassState> classes_;
  ConnectivityGrid connectivity_;
  ContourSet contours_;

  // Per-frame cache of classifications: a cell's class is valid while its stamp is the frame's.
  const CellClassifier* classifier_ = nullptr;
  std::vector<std::uint32_t> classifiedStamp_;
  std::vector<ClassId> classifiedClass_;
  std::uint32_t stamp_ = 0;

  // Scratch for initial searches and dropRegion, kept to avoid per-frame allocation.
  std::vector<Cell> scratchQueue_;
  std::vector<std::uint8_t> scratchMark_;
  struct SeedCandidate {
    int cells;
    Cell seed;
  };
  std::vector<SeedCandidate> seedCandidates_;

  std::int64_t frameCount_ = 0;
  TrackingStats stats_;
};

}  // namespace fieldline::region_tracking
