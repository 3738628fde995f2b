#include "services/region_tracking/region_tracker.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "common/config/config.hpp"

namespace fieldline::region_tracking {

TrackerConfig loadTrackerConfig(
    const config::Node& node,
    const std::function<std::optional<ClassId>(const std::string&)>& classByName) {
  TrackerConfig config;
  config.cellSize = node.get<int>("cell_size", 1, 8);
  if (config.cellSize != 1 && config.cellSize != 2 && config.cellSize != 4 &&
      config.cellSize != 8) {
    node.fail("cell_size", "must be 1, 2, 4 or 8");
  }
  config.reinitialisePeriodFrames = node.get<int>("reinitialise_period_frames", 0, 1000000);
  auto classAt = [&](const config::Node& entry, const std::string& key) {
    const std::optional<ClassId> id = classByName(entry.get<std::string>(key));
    if (!id || *id == kNoClass) entry.fail(key, "unknown colour class");
    return *id;
  };
  for (const config::Node& entry : node.children("classes")) {
    ClassTracking tracking;
    tracking.classId = classAt(entry, "class");
    tracking.searchWhenLost = entry.getOr<bool>("search_when_lost", true);
    tracking.maxSeedRegions = entry.getOr<int>("max_seed_regions", 10, 1, 1000);
    tracking.minSeedCells = entry.getOr<int>("min_seed_cells", 4, 1, 1000000);
    tracking.viewEdgeStride = entry.getOr<int>("view_edge_stride", 0, 0, 64);
    tracking.searchInsideParentStride = entry.getOr<int>("search_inside_parent_stride", 0, 0, 16);
    if (entry.has("seed_from_boundary_of")) {
      tracking.seedFromBoundaryOf = classAt(entry, "seed_from_boundary_of");
    }
    entry.rejectUnknownKeys();
    for (const ClassTracking& earlier : config.classes) {
      if (earlier.classId == tracking.classId) entry.fail("class", "listed twice");
    }
    if (tracking.seedFromBoundaryOf != kNoClass &&
        std::none_of(config.classes.begin(), config.classes.end(), [&](const ClassTracking& c) {
          return c.classId == tracking.seedFromBoundaryOf;
        })) {
      entry.fail("seed_from_boundary_of", "must name a class listed before this one");
    }
    config.classes.push_back(tracking);
  }
  node.rejectUnknownKeys();
  return config;
}

RegionTracker::RegionTracker(const CellGrid& grid, const TrackerConfig& config,
                             std::vector<std::uint8_t> dontTouch)
    : grid_(grid),
      layout_(grid),
      neighbour_{layout_.neighbour(0), layout_.neighbour(1), layout_.neighbour(2),
                 layout_.neighbour(3)},
      config_(config),
      visited_(layout_.size(), kBlocked),
      connectivity_(grid),
      classified_(layout_.size(), 0),
      coordinates_(layout_.size(), Cell{-1, -1}),
      scratchMark_(layout_.size(), 0) {
  classSlot_.fill(-1);
  seedParent_.fill(kNoClass);
  if (grid.width <= 0 || grid.height <= 0 || grid.width > 32767 || grid.height > 32767) {
    throw std::invalid_argument("region tracker: grid size out of range");
  }
  if (config.cellSize != grid.cellSize) {
    throw std::invalid_argument("region tracker: config cell size differs from the grid's");
  }
  if (!dontTouch.empty() && static_cast<int>(dontTouch.size()) != grid.cellCount()) {
    throw std::invalid_argument("region tracker: don't-touch mask must have one byte per cell");
  }
  // V starts as the frame of blocked cells around the grid plus the don't-touch cells.
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      const bool forbidden = !dontTouch.empty() && dontTouch[grid.index(x, y)];
      visited_[layout_.index(x, y)] = forbidden ? kBlocked : kNoClass;
    }
  }
  emptyVisited_ = visited_;
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x)
      coordinates_[layout_.index(x, y)] = {static_cast<std::int16_t>(x),
                                           static_cast<std::int16_t>(y)};
  }

  for (std::size_t i = 0; i < config.classes.size(); ++i) {
    const ClassTracking& tracking = config.classes[i];
    if (tracking.classId == kNoClass || tracking.classId == kBlocked) {
      throw std::invalid_argument("region tracker: class ids 254 and 255 are reserved");
    }
    if (tracking.maxSeedRegions < 1 || tracking.minSeedCells < 1 || tracking.viewEdgeStride < 0 ||
        tracking.searchInsideParentStride < 0) {
      throw std::invalid_argument("region tracker: seed limits must be positive");
    }
    if (tracking.searchInsideParentStride > 0 && tracking.seedFromBoundaryOf == kNoClass) {
      throw std::invalid_argument("region tracker: search_inside_parent_stride of class " +
                                  std::to_string(tracking.classId) +
                                  " needs seed_from_boundary_of");
    }
    for (std::size_t j = 0; j < config.classes.size(); ++j) {
      if (j != i && config.classes[j].classId == tracking.classId) {
        throw std::invalid_argument("region tracker: class " + std::to_string(tracking.classId) +
                                    " listed twice");
      }
    }
    if (tracking.seedFromBoundaryOf != kNoClass) {
      const bool parentEarlier = std::any_of(
          config.classes.begin(), config.classes.begin() + i,
          [&](const ClassTracking& c) { return c.classId == tracking.seedFromBoundaryOf; });
      if (!parentEarlier) {
        throw std::invalid_argument("region tracker: seed_from_boundary_of of class " +
                                    std::to_string(tracking.classId) +
                                    " must name a class listed before it");
      }
    }
    ClassState state;
    state.tracking = tracking;
    // Reserve the worst case once so no frame ever allocates (a cell can be proposed as a
    // seed from each of its four sides).
    state.workDrops.reserve(grid.cellCount());
    state.boundaryDrops.reserve(grid.cellCount());
    state.pendingSeeds.reserve(4 * static_cast<std::size_t>(grid.cellCount()));
    classSlot_[tracking.classId] = static_cast<int>(classes_.size());
    seedParent_[tracking.classId] = tracking.seedFromBoundaryOf;
    classes_.push_back(std::move(state));
  }
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      const CellIndex cell = layout_.index(x, y);
      if (visited_[cell] == kBlocked) continue;
      for (int side = 0; side < 4; ++side) {
        if (visited_[cell + neighbour_[side]] == kBlocked) {
          viewEdge_.push_back(cell);
          break;
        }
      }
    }
  }
  scratchQueue_.reserve(grid.cellCount());
  seedCandidates_.reserve(grid.cellCount());
  contours_.points.reserve(4 * grid.cellCount() / 8 + 64);
}

RegionTracker::ClassState* RegionTracker::stateOf(ClassId classId) {
  const int slot = classSlot_[classId];
  return slot < 0 ? nullptr : &classes_[slot];
}

std::vector<ClassId> RegionTracker::visited() const {
  std::vector<ClassId> out(grid_.cellCount());
  for (int y = 0; y < grid_.height; ++y) {
    for (int x = 0; x < grid_.width; ++x)
      out[grid_.index(x, y)] = ownerOf(x, y);
  }
  return out;
}

int RegionTracker::regionCells(ClassId classId) const {
  const int slot = classSlot_[classId];
  return slot < 0 ? 0 : classes_[slot].cells;
}

ClassId RegionTracker::classifyNow(CellIndex cell) {
  const Cell at = coordinates_[cell];
  const ClassId classId = classifier_->classify(at.x, at.y);
  classified_[cell] = (stamp_ << 8) | classId;
  ++stats_.cellsClassified;
  ++stats_.classifiedBy[static_cast<int>(touchReason_)];
  return classId;
}

const TrackingStats& RegionTracker::track(const CellClassifier& classifier) {
  stats_ = TrackingStats{};
  stats_.frame = frameCount_;
  classifier_ = &classifier;
  if (++stamp_ == kStampLimit) {  // wrapped after 2^24 frames: old stamps could look current
    std::fill(classified_.begin(), classified_.end(), 0);
    stamp_ = 1;
  }
  const int period = config_.reinitialisePeriodFrames;
  if (period > 0 && frameCount_ > 0 && frameCount_ % period == 0) {
    reinitialise();
    stats_.reinitialised = true;
  }
  auto totalCells = [this] {
    int sum = 0;
    for (const ClassState& state : classes_)
      sum += state.cells;
    return sum;
  };

  stats_.cellsBefore = totalCells();
  touchReason_ = TouchReason::kInsideParent;
  for (const ClassState& state : classes_) {
    const int stride = state.tracking.searchInsideParentStride;
    if (state.cells == 0 && stride > 0 && state.framesLost <= 2 * stride * stride) {
      searchInsideParent(state);
    }
  }
  touchReason_ = TouchReason::kShrink;
  for (ClassState& state : classes_)
    shrink(state);
  stats_.cellsAfterShrink = totalCells();

  contours_.clear();
  for (ClassState& state : classes_) {
    touchReason_ = TouchReason::kSeed;
    seedPending(state);
    // Lost: nothing carried over and no seed given. (Seeds at the view's edge come after this
    // check: a sliver entering the view must not stand in for the search.)
    if (state.cells == 0 && state.tracking.searchWhenLost) {
      touchReason_ = TouchReason::kInitialSearch;
      initialSearch(state);
      ++stats_.initialSearches;
    }
    touchReason_ = TouchReason::kViewEdge;
    if (state.tracking.viewEdgeStride > 0) seedAtViewEdge(state);
    touchReason_ = TouchReason::kGrow;
    grow(state);
    connectivity_.extractContoursAt(state.boundaryDrops, state.tracking.classId, contours_);
  }
  stats_.cellsAfterGrow = totalCells();
  for (ClassState& state : classes_) {
    if (state.cells > 0) {
      state.framesLost = 0;
    } else if (state.framesLost < kNeverSeen) {
      ++state.framesLost;
    }
  }

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
  ClassId* const visited = visited_.data();
  const int up = neighbour_[0], right = neighbour_[1], down = neighbour_[2], left = neighbour_[3];
  std::vector<CellIndex>& drops = state.boundaryDrops;
  std::vector<CellIndex>& stopped = state.workDrops;
  // Drops stand on unmarked cells while shrinking, so unmark the boundary drops first.
  for (const CellIndex drop : drops)
    visited[drop] = kNoClass;
  int cells = state.cells - static_cast<int>(drops.size());
  int processed = 0;
  // Every cell is pushed at most once (it is unmarked when pushed), so the reserved capacity of
  // one entry per cell is never exceeded.
  auto moveInto = [&](CellIndex next) {
    if (visited[next] == id) {
      visited[next] = kNoClass;
      --cells;
      drops.push_back(next);
    }
  };
  // Shrinking starts only at the boundary: a change deep inside a region that touches no
  // boundary drop (a ball jumping into green) is not seen here (seed 3.1.5); see
  // searchInsideParent for the remedy used for small, fast classes.
  while (!drops.empty()) {
    const CellIndex drop = drops.back();
    drops.pop_back();
    ++processed;
    if (classOf(drop) == id) {
      // Still the region's class: the drop stops here and will seed the growing.
      stopped.push_back(drop);
      continue;
    }
    // The cell left the region: the drop moves into every still-marked neighbour.
    moveInto(drop + up);
    moveInto(drop + right);
    moveInto(drop + down);
    moveInto(drop + left);
  }
  // The stopped drops belong to the region again.
  for (const CellIndex drop : stopped)
    visited[drop] = id;
  state.cells = cells + static_cast<int>(stopped.size());
  stats_.dropsProcessed += processed;
}

// Procedure 1: grow the regions of one class from their drops to their full extent, collecting
// the boundary drops for the next shrink and the boundary sides for contour extraction.
void RegionTracker::grow(ClassState& state) {
  const ClassId id = state.tracking.classId;
  ClassId* const visited = visited_.data();
  const ClassId* const seedParent = seedParent_.data();
  std::vector<CellIndex>& drops = state.workDrops;
  std::vector<CellIndex>& boundary = state.boundaryDrops;
  int cells = state.cells;
  int processed = 0;
  // Looks at the neighbour on one side; true if that side is on the region's boundary.
  auto spreadTo = [&](CellIndex next) {
    const ClassId owner = visited[next];
    if (owner == id) return false;  // inside the region
    if (owner == kNoClass) {
      const ClassId nextClass = classOf(next);
      if (nextClass == id) {
        visited[next] = id;
        ++cells;
        drops.push_back(next);
        return false;
      }
      if (seedParent[nextClass] == id) {
        // An untracked region of a class seeded from this one's boundary (the ball next to
        // green): it grows when its class's turn comes.
        classes_[classSlot_[nextClass]].pendingSeeds.push_back(next);
      }
    }
    // Another class, blocked, or unvisited of another class: a boundary side.
    return true;
  };
  const int up = neighbour_[0], right = neighbour_[1], down = neighbour_[2], left = neighbour_[3];
  while (!drops.empty()) {
    const CellIndex drop = drops.back();
    drops.pop_back();
    ++processed;
    const unsigned sides = (spreadTo(drop + up) ? 1u : 0u) | (spreadTo(drop + right) ? 2u : 0u) |
                           (spreadTo(drop + down) ? 4u : 0u) | (spreadTo(drop + left) ? 8u : 0u);
    if (sides != 0) {
      connectivity_.addBoundarySidesAt(drop, sides);
      boundary.push_back(drop);
    }
  }
  state.cells = cells;
  stats_.dropsProcessed += processed;
}

void RegionTracker::seedPending(ClassState& state) {
  for (const CellIndex seed : state.pendingSeeds) {
    if (visited_[seed] == kNoClass && classOf(seed) == state.tracking.classId) claim(state, seed);
  }
  state.pendingSeeds.clear();
}

void RegionTracker::seedAtViewEdge(ClassState& state) {
  const std::size_t stride = static_cast<std::size_t>(state.tracking.viewEdgeStride);
  for (std::size_t i = static_cast<std::size_t>(frameCount_) % stride; i < viewEdge_.size();
       i += stride) {
    const CellIndex cell = viewEdge_[i];
    if (visited_[cell] == kNoClass && classOf(cell) == state.tracking.classId) claim(state, cell);
  }
}

// Against the blind spot: the lost class `child` may sit inside its parent's regions, on cells
// the parent still claims from earlier frames. Check a sparse, rotating subset of the parent's
// interior cells; a stale one becomes a boundary drop of the parent, so the coming shrink carves
// the island out and the parent's grow seeds `child` from the island's new boundary.
void RegionTracker::searchInsideParent(const ClassState& child) {
  ClassState* parent = stateOf(child.tracking.seedFromBoundaryOf);
  if (parent == nullptr || parent->cells == 0) return;
  const ClassId parentId = parent->tracking.classId;
  const int stride = child.tracking.searchInsideParentStride;
  const int phase = static_cast<int>(frameCount_ % (stride * stride));
  for (int y = phase / stride; y < grid_.height; y += stride) {
    for (int x = phase % stride; x < grid_.width; x += stride) {
      const CellIndex cell = layout_.index(x, y);
      if (visited_[cell] != parentId) continue;
      // A cell on the region's edge is a boundary drop already: shrink checks it anyway (and a
      // cell must not be a drop twice).
      bool interior = true;
      for (const int offset : neighbour_)
        interior = interior && visited_[cell + offset] == parentId;
      if (interior && classOf(cell) != parentId) parent->boundaryDrops.push_back(cell);
    }
  }
}

// Seed 3.1.7: measure every untracked region of the class in the whole frame and seed the
// largest ones with one drop each.
void RegionTracker::initialSearch(ClassState& state) {
  const ClassId id = state.tracking.classId;
  seedCandidates_.clear();
  for (int y = 0; y < grid_.height; ++y) {
    for (int x = 0; x < grid_.width; ++x) {
      const CellIndex start = layout_.index(x, y);
      if (scratchMark_[start] || visited_[start] != kNoClass || classOf(start) != id) continue;
      // Flood the region on the scratch marks to measure its size.
      int size = 0;
      scratchMark_[start] = 1;
      scratchQueue_.push_back(start);
      while (!scratchQueue_.empty()) {
        const CellIndex cell = scratchQueue_.back();
        scratchQueue_.pop_back();
        ++size;
        for (const int offset : neighbour_) {
          const CellIndex next = cell + offset;
          if (!scratchMark_[next] && visited_[next] == kNoClass && classOf(next) == id) {
            scratchMark_[next] = 1;
            scratchQueue_.push_back(next);
          }
        }
      }
      if (size >= state.tracking.minSeedCells) seedCandidates_.push_back({size, start});
    }
  }
  std::fill(scratchMark_.begin(), scratchMark_.end(), 0);

  const auto seeds = std::min<std::size_t>(seedCandidates_.size(), state.tracking.maxSeedRegions);
  std::partial_sort(
      seedCandidates_.begin(), seedCandidates_.begin() + seeds, seedCandidates_.end(),
      [](const SeedCandidate& a, const SeedCandidate& b) { return a.cells > b.cells; });
  for (std::size_t i = 0; i < seeds; ++i)
    claim(state, seedCandidates_[i].seed);
}

int RegionTracker::dropRegion(ClassId classId, int x, int y) {
  ClassState* state = stateOf(classId);
  if (state == nullptr || !grid_.contains(x, y)) return 0;
  const CellIndex start = layout_.index(x, y);
  if (visited_[start] != classId) return 0;
  // Shrinking without a stopping criterion: unmark the whole connected region.
  int released = 0;
  visited_[start] = kNoClass;
  scratchQueue_.push_back(start);
  while (!scratchQueue_.empty()) {
    const CellIndex cell = scratchQueue_.back();
    scratchQueue_.pop_back();
    ++released;
    for (const int offset : neighbour_) {
      const CellIndex next = cell + offset;
      if (visited_[next] == classId) {
        visited_[next] = kNoClass;
        scratchQueue_.push_back(next);
      }
    }
  }
  state->cells -= released;
  // Its boundary drops must go too, or the next shrink would revive the region.
  std::erase_if(state->boundaryDrops, [&](const CellIndex d) { return visited_[d] != classId; });
  return released;
}

void RegionTracker::dropClass(ClassId classId) {
  ClassState* state = stateOf(classId);
  if (state == nullptr) return;
  std::replace(visited_.begin(), visited_.end(), classId, kNoClass);
  state->workDrops.clear();
  state->boundaryDrops.clear();
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
  state->pendingSeeds.push_back(layout_.index(x, y));
}

void RegionTracker::reinitialise() {
  visited_ = emptyVisited_;
  for (ClassState& state : classes_) {
    state.workDrops.clear();
    state.boundaryDrops.clear();
    state.cells = 0;
  }
}

}  // namespace fieldline::region_tracking
