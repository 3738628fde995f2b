#include "services/region_tracking/region_tracker.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "common/config/config.hpp"

namespace fieldline::region_tracking {

TrackerConfig loadTrackerConfig(const config::Node& node) {
  TrackerConfig config;
  config.cellSize = node.get<int>("cell_size", 1, 8);
  if (config.cellSize != 1 && config.cellSize != 2 && config.cellSize != 4 &&
      config.cellSize != 8) {
    node.fail("cell_size", "must be 1, 2, 4 or 8");
  }
  config.reinitialisePeriodFrames = node.get<int>("reinitialise_period_frames", 0, 1000000);
  for (const config::Node& entry : node.children("classes")) {
    ClassTracking tracking;
    tracking.classId = static_cast<ClassId>(entry.get<int>("class_id", 0, kNoClass - 1));
    tracking.searchWhenLost = entry.getOr<bool>("search_when_lost", true);
    tracking.maxSeedRegions = entry.getOr<int>("max_seed_regions", 10, 1, 1000);
    tracking.minSeedCells = entry.getOr<int>("min_seed_cells", 4, 1, 1000000);
    tracking.seedFromBoundaryOf =
        static_cast<ClassId>(entry.getOr<int>("seed_from_boundary_of", kNoClass, 0, kNoClass));
    entry.rejectUnknownKeys();
    config.classes.push_back(tracking);
  }
  node.rejectUnknownKeys();
  return config;
}

RegionTracker::RegionTracker(const CellGrid& grid, const TrackerConfig& config,
                             std::vector<std::uint8_t> dontTouch)
    : grid_(grid),
      config_(config),
      dontTouch_(std::move(dontTouch)),
      visited_(grid.cellCount(), kNoClass),
      connectivity_(grid),
      classifiedStamp_(grid.cellCount(), 0),
      classifiedClass_(grid.cellCount(), kNoClass),
      scratchMark_(grid.cellCount(), 0) {
  if (grid.width <= 0 || grid.height <= 0 || grid.width > 32767 || grid.height > 32767) {
    throw std::invalid_argument("region tracker: grid size out of range");
  }
  if (config.cellSize != grid.cellSize) {
    throw std::invalid_argument("region tracker: config cell size differs from the grid's");
  }
  if (dontTouch_.empty()) dontTouch_.assign(grid.cellCount(), 0);
  if (static_cast<int>(dontTouch_.size()) != grid.cellCount()) {
    throw std::invalid_argument("region tracker: don't-touch mask must have one byte per cell");
  }
  for (std::size_t i = 0; i < config.classes.size(); ++i) {
    const ClassTracking& tracking = config.classes[i];
    if (tracking.classId == kNoClass) {
      throw std::invalid_argument("region tracker: class id 255 is reserved");
    }
    if (tracking.maxSeedRegions < 1 || tracking.minSeedCells < 1) {
      throw std::invalid_argument("region tracker: seed limits must be positive");
    }
    for (std::size_t j = 0; j < config.classes.size(); ++j) {
      if (j != i && config.classes[j].classId == tracking.classId) {
        throw std::invalid_argument("region tracker: class " + std::to_string(tracking.classId) +
                                    " listed twice");
      }
    }
    if (tracking.seedFromBoundaryOf != kNoClass) {
      const bool parentEarlier =
          std::any_of(config.classes.begin(), config.classes.begin() + i,
                      [&](const ClassTracking& c) { return c.classId == tracking.seedFromBoundaryOf; });
      if (!parentEarlier) {
        throw std::invalid_argument("region tracker: seed_from_boundary_of of class " +
                                    std::to_string(tracking.classId) +
                                    " must name a class listed before it");
      }
    }
    ClassState state;
    state.tracking = tracking;
    // Reserve the worst case once so no frame ever allocates.
    state.growDrops.reserve(grid.cellCount());
    state.shrinkDrops.reserve(grid.cellCount());
    classes_.push_back(std::move(state));
  }
  scratchQueue_.reserve(grid.cellCount());
  contours_.points.reserve(4 * grid.cellCount() / 8 + 64);
}

RegionTracker::ClassState* RegionTracker::stateOf(ClassId classId) {
  for (ClassState& state : classes_) {
    if (state.tracking.classId == classId) return &state;
  }
  return nullptr;
}

std::span<const Cell> RegionTracker::boundaryCells(ClassId classId) const {
  for (const ClassState& state : classes_) {
    if (state.tracking.classId == classId) return state.shrinkDrops;
  }
  return {};
}

int RegionTracker::regionCells(ClassId classId) const {
  for (const ClassState& state : classes_) {
    if (state.tracking.classId == classId) return state.cells;
  }
  return 0;
}

ClassId RegionTracker::classOf(int x, int y) {
  const int index = grid_.index(x, y);
  if (classifiedStamp_[index] != stamp_) {
    classifiedStamp_[index] = stamp_;
    classifiedClass_[index] = classifier_->classify(x, y);
    ++stats_.cellsClassified;
  }
  return classifiedClass_[index];
}

const TrackingStats& RegionTracker::track(const CellClassifier& classifier) {
  stats_ = TrackingStats{};
  stats_.frame = frameCount_;
  classifier_ = &classifier;
  if (++stamp_ == 0) {  // wrapped after 2^32 frames: old stamps could look current
    std::fill(classifiedStamp_.begin(), classifiedStamp_.end(), 0);
    stamp_ = 1;
  }
  const int period = config_.reinitialisePeriodFrames;
  if (period > 0 && frameCount_ > 0 && frameCount_ % period == 0) {
    reinitialise();
    stats_.reinitialised = true;
  }
  auto totalCells = [this] {
    int sum = 0;
    for (const ClassState& state : classes_) sum += state.cells;
    return sum;
  };

  stats_.cellsBefore = totalCells();
  for (ClassState& state : classes_) shrink(state);
  stats_.cellsAfterShrink = totalCells();

  contours_.clear();
  for (ClassState& state : classes_) {
    seedPending(state);
    if (state.tracking.seedFromBoundaryOf != kNoClass) {
      seedFromBoundary(state, *stateOf(state.tracking.seedFromBoundaryOf));
    }
    if (state.cells == 0 && state.tracking.searchWhenLost) {
      initialSearch(state);
      ++stats_.initialSearches;
    }
    grow(state);
    connectivity_.extractContours(state.shrinkDrops, state.tracking.classId, contours_);
  }
  stats_.cellsAfterGrow = totalCells();

  stats_.touchedFraction = static_cast<double>(stats_.cellsClassified) / grid_.cellCount();
  stats_.overlap = stats_.cellsAfterGrow > 0
                       ? static_cast<double>(stats_.cellsAfterShrink) / stats_.cellsAfterGrow
                       : 0.0;
  stats_.contours = static_cast<int>(contours_.contours.size());
  classifier_ = nullptr;
  ++frameCount_;
  return stats_;
}

// Procedure 2: shrink the regions of one class to their overlap with the new frame.
void RegionTracker::shrink(ClassState& state) {
  const ClassId id = state.tracking.classId;
  // Drops stand on unmarked cells while shrinking, so unmark the boundary drops first.
  for (const Cell drop : state.shrinkDrops) {
    visited_[grid_.index(drop.x, drop.y)] = kNoClass;
    --state.cells;
  }
  while (!state.shrinkDrops.empty()) {
    const Cell drop = state.shrinkDrops.back();
    state.shrinkDrops.pop_back();
    ++stats_.dropsProcessed;
    if (classOf(drop.x, drop.y) == id) {
      // Still the region's class: the drop stops here and will seed the growing.
      state.growDrops.push_back(drop);
      continue;
    }
    // The cell left the region: the drop moves into every still-marked neighbour.
    for (int side = 0; side < 4; ++side) {
      const int x = drop.x + kSideDx[side];
      const int y = drop.y + kSideDy[side];
      if (!grid_.contains(x, y)) continue;
      ClassId& owner = visited_[grid_.index(x, y)];
      if (owner == id) {
        owner = kNoClass;
        --state.cells;
        state.shrinkDrops.push_back({static_cast<std::int16_t>(x), static_cast<std::int16_t>(y)});
      }
    }
  }
  // The stopped drops belong to the region again.
  for (const Cell drop : state.growDrops) {
    visited_[grid_.index(drop.x, drop.y)] = id;
    ++state.cells;
  }
}

// Procedure 1: grow the regions of one class from their drops to their full extent, collecting
// the boundary drops for the next shrink and the boundary sides for contour extraction.
void RegionTracker::grow(ClassState& state) {
  const ClassId id = state.tracking.classId;
  while (!state.growDrops.empty()) {
    const Cell drop = state.growDrops.back();
    state.growDrops.pop_back();
    ++stats_.dropsProcessed;
    bool atBoundary = false;
    for (int side = 0; side < 4; ++side) {
      const int x = drop.x + kSideDx[side];
      const int y = drop.y + kSideDy[side];
      bool outside = true;
      if (!blocked(x, y)) {
        ClassId& owner = visited_[grid_.index(x, y)];
        if (owner == id) {
          outside = false;
        } else if (owner == kNoClass && classOf(x, y) == id) {
          owner = id;
          ++state.cells;
          state.growDrops.push_back({static_cast<std::int16_t>(x), static_cast<std::int16_t>(y)});
          outside = false;
        }
      }
      if (outside) {
        connectivity_.addBoundarySide(drop.x, drop.y, side);
        atBoundary = true;
      }
    }
    if (atBoundary) state.shrinkDrops.push_back(drop);
  }
}

void RegionTracker::seedFromBoundary(ClassState& state, const ClassState& parent) {
  const ClassId id = state.tracking.classId;
  for (const Cell drop : parent.shrinkDrops) {
    for (int side = 0; side < 4; ++side) {
      const int x = drop.x + kSideDx[side];
      const int y = drop.y + kSideDy[side];
      if (blocked(x, y)) continue;
      ClassId& owner = visited_[grid_.index(x, y)];
      if (owner == kNoClass && classOf(x, y) == id) {
        owner = id;
        ++state.cells;
        state.growDrops.push_back({static_cast<std::int16_t>(x), static_cast<std::int16_t>(y)});
      }
    }
  }
}

void RegionTracker::seedPending(ClassState& state) {
  const ClassId id = state.tracking.classId;
  for (const Cell seed : state.pendingSeeds) {
    if (blocked(seed.x, seed.y)) continue;
    ClassId& owner = visited_[grid_.index(seed.x, seed.y)];
    if (owner == kNoClass && classOf(seed.x, seed.y) == id) {
      owner = id;
      ++state.cells;
      state.growDrops.push_back(seed);
    }
  }
  state.pendingSeeds.clear();
}

// Seed 3.1.7: measure every untracked region of the class in the whole frame and seed the
// largest ones with one drop each.
bool RegionTracker::initialSearch(ClassState& state) {
  const ClassId id = state.tracking.classId;
  seedCandidates_.clear();
  for (int y = 0; y < grid_.height; ++y) {
    for (int x = 0; x < grid_.width; ++x) {
      const int start = grid_.index(x, y);
      if (scratchMark_[start] || dontTouch_[start] || visited_[start] != kNoClass ||
          classOf(x, y) != id) {
        continue;
      }
      // Flood the region on the scratch marks to measure its size.
      int size = 0;
      scratchMark_[start] = 1;
      scratchQueue_.push_back({static_cast<std::int16_t>(x), static_cast<std::int16_t>(y)});
      while (!scratchQueue_.empty()) {
        const Cell cell = scratchQueue_.back();
        scratchQueue_.pop_back();
        ++size;
        for (int side = 0; side < 4; ++side) {
          const int nx = cell.x + kSideDx[side];
          const int ny = cell.y + kSideDy[side];
          if (blocked(nx, ny)) continue;
          const int index = grid_.index(nx, ny);
          if (!scratchMark_[index] && visited_[index] == kNoClass && classOf(nx, ny) == id) {
            scratchMark_[index] = 1;
            scratchQueue_.push_back(
                {static_cast<std::int16_t>(nx), static_cast<std::int16_t>(ny)});
          }
        }
      }
      if (size >= state.tracking.minSeedCells) {
        seedCandidates_.push_back(
            {size, {static_cast<std::int16_t>(x), static_cast<std::int16_t>(y)}});
      }
    }
  }
  std::fill(scratchMark_.begin(), scratchMark_.end(), 0);

  const auto seeds = std::min<std::size_t>(seedCandidates_.size(), state.tracking.maxSeedRegions);
  std::partial_sort(seedCandidates_.begin(), seedCandidates_.begin() + seeds,
                    seedCandidates_.end(),
                    [](const SeedCandidate& a, const SeedCandidate& b) { return a.cells > b.cells; });
  for (std::size_t i = 0; i < seeds; ++i) {
    const Cell seed = seedCandidates_[i].seed;
    visited_[grid_.index(seed.x, seed.y)] = id;
    ++state.cells;
    state.growDrops.push_back(seed);
  }
  return seeds > 0;
}

int RegionTracker::dropRegion(ClassId classId, int x, int y) {
  ClassState* state = stateOf(classId);
  if (state == nullptr || !grid_.contains(x, y) || visited_[grid_.index(x, y)] != classId) {
    return 0;
  }
  // Shrinking without a stopping criterion: unmark the whole connected region.
  int released = 0;
  visited_[grid_.index(x, y)] = kNoClass;
  scratchQueue_.push_back({static_cast<std::int16_t>(x), static_cast<std::int16_t>(y)});
  while (!scratchQueue_.empty()) {
    const Cell cell = scratchQueue_.back();
    scratchQueue_.pop_back();
    ++released;
    for (int side = 0; side < 4; ++side) {
      const int nx = cell.x + kSideDx[side];
      const int ny = cell.y + kSideDy[side];
      if (!grid_.contains(nx, ny)) continue;
      ClassId& owner = visited_[grid_.index(nx, ny)];
      if (owner == classId) {
        owner = kNoClass;
        scratchQueue_.push_back({static_cast<std::int16_t>(nx), static_cast<std::int16_t>(ny)});
      }
    }
  }
  state->cells -= released;
  // Its boundary drops must go too, or the next shrink would revive the region.
  std::erase_if(state->shrinkDrops,
                [&](const Cell d) { return visited_[grid_.index(d.x, d.y)] != classId; });
  return released;
}

void RegionTracker::dropClass(ClassId classId) {
  ClassState* state = stateOf(classId);
  if (state == nullptr) return;
  std::replace(visited_.begin(), visited_.end(), classId, kNoClass);
  state->growDrops.clear();
  state->shrinkDrops.clear();
  state->pendingSeeds.clear();
  state->cells = 0;
}

void RegionTracker::addSeed(ClassId classId, int x, int y) {
  ClassState* state = stateOf(classId);
  if (state == nullptr) {
    throw std::invalid_argument("region tracker: seed for untracked class " +
                                std::to_string(classId));
  }
  if (!grid_.contains(x, y)) throw std::out_of_range("region tracker: seed outside the grid");
  state->pendingSeeds.push_back({static_cast<std::int16_t>(x), static_cast<std::int16_t>(y)});
}

void RegionTracker::reinitialise() {
  std::fill(visited_.begin(), visited_.end(), kNoClass);
  for (ClassState& state : classes_) {
    state.growDrops.clear();
    state.shrinkDrops.clear();
    state.cells = 0;
  }
}

}  // namespace fieldline::region_tracking
