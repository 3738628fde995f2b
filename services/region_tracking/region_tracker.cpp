#include "services/region_tracking/region_tracker.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

#include "common/config/config.hpp"

namespace fieldline::region_tracking {

TrackerConfig loadTrackerConfig(
    const config::Node& node,
    const std::function<std::optional<ClassId>(const std::string&)>& classByName) {
  TrackerConfig config;
  config.cell_size = node.get<int>("cell_size", 1, 8);
  if (config.cell_size != 1 && config.cell_size != 2 && config.cell_size != 4 &&
      config.cell_size != 8) {
    node.fail("cell_size", "must be 1, 2, 4 or 8");
  }
  config.reinitialise_period_frames = node.get<int>("reinitialise_period_frames", 0, 1000000);
  config.mask_edge_every = node.getOr<int>("mask_edge_every", 1, 1, 16);
  config.mask_edge_inner = node.getOr<bool>("mask_edge_inner", false);
  auto classAt = [&](const config::Node& entry, const std::string& key) {
    const std::optional<ClassId> id = classByName(entry.get<std::string>(key));
    if (!id || *id == kNoClass) entry.fail(key, "unknown colour class");
    return *id;
  };
  for (const config::Node& entry : node.children("classes")) {
    ClassTracking tracking;
    tracking.class_id = classAt(entry, "class");
    tracking.search_when_lost = entry.getOr<bool>("search_when_lost", true);
    tracking.max_seed_regions = entry.getOr<int>("max_seed_regions", 0, 0, 1000);
    tracking.min_seed_cells = entry.getOr<int>("min_seed_cells", 4, 1, 1000000);
    tracking.view_edge_stride = entry.getOr<int>("view_edge_stride", 0, 0, 64);
    tracking.search_inside_parent_stride =
        entry.getOr<int>("search_inside_parent_stride", 0, 0, 16);
    if (entry.has("seed_from_boundary_of")) {
      tracking.seed_from_boundary_of = classAt(entry, "seed_from_boundary_of");
    }
    entry.rejectUnknownKeys();
    for (const ClassTracking& earlier : config.classes) {
      if (earlier.class_id == tracking.class_id) entry.fail("class", "listed twice");
    }
    if (tracking.seed_from_boundary_of != kNoClass &&
        std::none_of(config.classes.begin(), config.classes.end(), [&](const ClassTracking& c) {
          return c.class_id == tracking.seed_from_boundary_of;
        })) {
      entry.fail("seed_from_boundary_of", "must name a class listed before this one");
    }
    config.classes.push_back(tracking);
  }
  node.rejectUnknownKeys();
  return config;
}

std::vector<int> stepsFromOuterRim(const CellGrid& grid, const std::vector<MaskEdge>& edges) {
  if (static_cast<int>(edges.size()) != grid.cellCount()) {
    throw std::invalid_argument("steps from the rim: the mask edges must have one entry per cell");
  }
  std::vector<int> steps(grid.cellCount(), -1);
  std::vector<int> queue;
  for (int c = 0; c < grid.cellCount(); ++c) {
    if (edges[c] == MaskEdge::kOuter) {
      steps[c] = 0;
      queue.push_back(c);
    }
  }
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const int c = queue[head], x = c % grid.width, y = c / grid.width;
    for (const auto& [nx, ny] : {std::pair{x + 1, y}, {x - 1, y}, {x, y + 1}, {x, y - 1}}) {
      if (grid.contains(nx, ny) && steps[grid.index(nx, ny)] < 0) {
        steps[grid.index(nx, ny)] = steps[c] + 1;
        queue.push_back(grid.index(nx, ny));
      }
    }
  }
  return steps;
}

std::vector<MaskEdge> maskEdges(const CellGrid& grid, std::span<const std::uint8_t> dontTouch) {
  std::vector<MaskEdge> edges(grid.cellCount(), MaskEdge::kNone);
  if (!dontTouch.empty() && static_cast<int>(dontTouch.size()) != grid.cellCount()) {
    throw std::invalid_argument("mask edges: the don't-touch mask must have one byte per cell");
  }
  auto blocked = [&](int x, int y) {
    return !grid.contains(x, y) || (!dontTouch.empty() && dontTouch[grid.index(x, y)] != 0);
  };
  // The blocked cells connected to the outside: flood from the blocked cells on the border.
  std::vector<std::uint8_t> outer(grid.cellCount(), 0);
  std::vector<int> stack;
  auto visit = [&](int x, int y) {
    if (grid.contains(x, y) && blocked(x, y) && !outer[grid.index(x, y)]) {
      outer[grid.index(x, y)] = 1;
      stack.push_back(grid.index(x, y));
    }
  };
  for (int x = 0; x < grid.width; ++x) {
    visit(x, 0);
    visit(x, grid.height - 1);
  }
  for (int y = 0; y < grid.height; ++y) {
    visit(0, y);
    visit(grid.width - 1, y);
  }
  while (!stack.empty()) {
    const int cell = stack.back();
    stack.pop_back();
    const int x = cell % grid.width, y = cell / grid.width;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx)
        visit(x + dx, y + dy);
    }
  }
  const int dx[4] = {0, 1, 0, -1}, dy[4] = {-1, 0, 1, 0};
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      if (blocked(x, y)) continue;
      MaskEdge edge = MaskEdge::kNone;
      for (int side = 0; side < 4; ++side) {
        const int nx = x + dx[side], ny = y + dy[side];
        if (!blocked(nx, ny)) continue;
        if (!grid.contains(nx, ny) || outer[grid.index(nx, ny)]) {
          edge = MaskEdge::kOuter;
          break;
        }
        edge = MaskEdge::kInner;
      }
      edges[grid.index(x, y)] = edge;
    }
  }
  return edges;
}

namespace {

void checkTrackerSetup(const CellGrid& grid, const TrackerConfig& config,
                       const std::vector<std::uint8_t>& dontTouch) {
  if (grid.width <= 0 || grid.height <= 0 || grid.width > 32767 || grid.height > 32767) {
    throw std::invalid_argument("region tracker: grid size out of range");
  }
  if (config.cell_size != grid.cell_size) {
    throw std::invalid_argument("region tracker: config cell size differs from the grid's");
  }
  if (!dontTouch.empty() && static_cast<int>(dontTouch.size()) != grid.cellCount()) {
    throw std::invalid_argument("region tracker: don't-touch mask must have one byte per cell");
  }
  if (config.mask_edge_every < 1) {
    throw std::invalid_argument("region tracker: mask_edge_every must be at least 1");
  }
}

}  // namespace

RegionTracker::RegionTracker(const CellGrid& grid, const TrackerConfig& config,
                             std::vector<std::uint8_t> dontTouch)
    : grid_(grid),
      layout_(grid, PaddedLayout::kPowerOfTwoPitch),
      neighbour_{layout_.neighbour(0), layout_.neighbour(1), layout_.neighbour(2),
                 layout_.neighbour(3)},
      config_(config),
      visited_(layout_.size(), kBlocked),
      connectivity_(grid, layout_),
      classified_(layout_.size(), 0),
      scratch_mark_(layout_.size(), 0) {
  class_slot_.fill(-1);
  seed_parent_.fill(kNoClass);
  checkTrackerSetup(grid, config, dontTouch);
  // V starts as the frame of blocked cells around the grid plus the don't-touch cells.
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      const bool forbidden = !dontTouch.empty() && dontTouch[grid.index(x, y)];
      visited_[layout_.index(x, y)] = forbidden ? kBlocked : kNoClass;
    }
  }
  empty_visited_ = visited_;
  for (std::size_t i = 0; i < config.classes.size(); ++i) {
    checkClass(config, i);
    addClass(config.classes[i]);
  }
  findViewEdge();
  if (config.mask_edge_every > 1) findDeferrableCells(dontTouch);
  scratch_queue_.reserve(grid.cellCount());
  seed_candidates_.reserve(grid.cellCount());
  contours_.points.reserve(4 * grid.cellCount() / 8 + 64);
}

void RegionTracker::checkClass(const TrackerConfig& config, std::size_t i) {
  const ClassTracking& tracking = config.classes[i];
  if (tracking.class_id == kNoClass || tracking.class_id == kBlocked) {
    throw std::invalid_argument("region tracker: class ids 254 and 255 are reserved");
  }
  if (tracking.max_seed_regions < 0 || tracking.min_seed_cells < 1 ||
      tracking.view_edge_stride < 0 || tracking.search_inside_parent_stride < 0) {
    throw std::invalid_argument("region tracker: seed limits must be positive");
  }
  if (tracking.search_inside_parent_stride > 0 && tracking.seed_from_boundary_of == kNoClass) {
    throw std::invalid_argument("region tracker: search_inside_parent_stride of class " +
                                std::to_string(tracking.class_id) + " needs seed_from_boundary_of");
  }
  for (std::size_t j = 0; j < config.classes.size(); ++j) {
    if (j != i && config.classes[j].class_id == tracking.class_id) {
      throw std::invalid_argument("region tracker: class " + std::to_string(tracking.class_id) +
                                  " listed twice");
    }
  }
  if (tracking.seed_from_boundary_of != kNoClass) {
    const bool parentEarlier = std::any_of(
        config.classes.begin(), config.classes.begin() + i,
        [&](const ClassTracking& c) { return c.class_id == tracking.seed_from_boundary_of; });
    if (!parentEarlier) {
      throw std::invalid_argument("region tracker: seed_from_boundary_of of class " +
                                  std::to_string(tracking.class_id) +
                                  " must name a class listed before it");
    }
  }
}

void RegionTracker::addClass(const ClassTracking& tracking) {
  ClassState state;
  state.tracking = tracking;
  // Reserve the worst case once so no frame ever allocates (a cell can be proposed as a seed
  // from each of its four sides).
  state.work_drops.allocate(grid_.cellCount());
  state.boundary_drops.allocate(grid_.cellCount());
  state.pending_seeds.reserve(4 * static_cast<std::size_t>(grid_.cellCount()));
  class_slot_[tracking.class_id] = static_cast<int>(classes_.size());
  seed_parent_[tracking.class_id] = tracking.seed_from_boundary_of;
  classes_.push_back(std::move(state));
}

void RegionTracker::findViewEdge() {
  for (int y = 0; y < grid_.height; ++y) {
    for (int x = 0; x < grid_.width; ++x) {
      const CellIndex cell = layout_.index(x, y);
      if (visited_[cell] == kBlocked) continue;
      for (int side = 0; side < 4; ++side) {
        if (visited_[cell + neighbour_[side]] == kBlocked) {
          view_edge_.push_back(cell);
          break;
        }
      }
    }
  }
}

void RegionTracker::findDeferrableCells(const std::vector<std::uint8_t>& dontTouch) {
  const std::vector<MaskEdge> edges = maskEdges(grid_, dontTouch);
  for (int y = 0; y < grid_.height; ++y) {
    for (int x = 0; x < grid_.width; ++x) {
      const MaskEdge edge = edges[grid_.index(x, y)];
      if (edge == MaskEdge::kOuter || (edge == MaskEdge::kInner && config_.mask_edge_inner)) {
        deferrable_.push_back({layout_.index(x, y), (x + y) % config_.mask_edge_every});
      }
    }
  }
}

RegionTracker::ClassState* RegionTracker::stateOf(ClassId class_id) {
  const int slot = class_slot_[class_id];
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

int RegionTracker::regionCells(ClassId class_id) const {
  const int slot = class_slot_[class_id];
  return slot < 0 ? 0 : classes_[slot].cells;
}

void RegionTracker::deferMaskEdge() {
  const int due = static_cast<int>(frame_count_ % config_.mask_edge_every);
  const auto deferred = static_cast<std::uint16_t>((stamp_ << 8) | kBlocked);
  for (const DeferrableCell& d : deferrable_) {
    if (d.phase != due) classified_[d.cell] = deferred;
  }
}

void RegionTracker::touchFor(TouchReason reason) {
  // The cells classified since the last switch were classified for the last reason. (Counting
  // here, not per cell, keeps the per-cell path to one counter.)
  stats_.classified_by[static_cast<int>(touch_reason_)] += stats_.cells_classified - reason_start_;
  touch_reason_ = reason;
  reason_start_ = stats_.cells_classified;
}

const TrackingStats& RegionTracker::track(const CellClassifier& classifier) {
  stats_ = TrackingStats{};
  stats_.frame = frame_count_;
  reason_start_ = 0;
  classifier_ = &classifier;
  if (++stamp_ == kStampLimit) {  // wrapped: old stamps could look current
    std::fill(classified_.begin(), classified_.end(), 0);
    stamp_ = 1;
  }
  const int period = config_.reinitialise_period_frames;
  if (period > 0 && frame_count_ > 0 && frame_count_ % period == 0) {
    reinitialise();
    stats_.reinitialised = true;
  }
  deferMaskEdge();
  auto totalCells = [this] {
    int sum = 0;
    for (const ClassState& state : classes_)
      sum += state.cells;
    return sum;
  };

  stats_.cells_before = totalCells();
  touchFor(TouchReason::kInsideParent);
  for (const ClassState& state : classes_) {
    const int stride = state.tracking.search_inside_parent_stride;
    if (state.cells == 0 && stride > 0 && state.frames_lost <= 2 * stride * stride) {
      searchInsideParent(state);
    }
  }
  touchFor(TouchReason::kShrink);
  for (ClassState& state : classes_)
    shrink(state);
  stats_.cells_after_shrink = totalCells();

  contours_.clear();
  for (ClassState& state : classes_) {
    touchFor(TouchReason::kSeed);
    seedPending(state);
    // Lost: nothing carried over and no seed given. (Seeds at the view's edge come after this
    // check: a sliver entering the view must not stand in for the search.)
    if (state.cells == 0 && state.tracking.search_when_lost) {
      touchFor(TouchReason::kInitialSearch);
      initialSearch(state);
      ++stats_.initial_searches;
    }
    touchFor(TouchReason::kViewEdge);
    if (state.tracking.view_edge_stride > 0) seedAtViewEdge(state);
    touchFor(TouchReason::kGrow);
    grow(state);
    connectivity_.extractContoursAt(state.boundary_drops, state.tracking.class_id, contours_);
  }
  touchFor(TouchReason::kShrink);  // books the last phase's cells
  stats_.cells_after_grow = totalCells();
  for (ClassState& state : classes_) {
    if (state.cells > 0) {
      state.frames_lost = 0;
    } else if (state.frames_lost < kNeverSeen) {
      ++state.frames_lost;
    }
  }

  stats_.touched_fraction = static_cast<double>(stats_.cells_classified) / grid_.cellCount();
  stats_.overlap = stats_.cells_after_grow > 0
                       ? static_cast<double>(stats_.cells_after_shrink) / stats_.cells_after_grow
                       : 0.0;
  stats_.contours = static_cast<int>(contours_.contours.size());
  classifier_ = nullptr;
  ++frame_count_;
  return stats_;
}

// Procedure 2: shrink the regions of one class to their overlap with the new frame.
void RegionTracker::shrink(ClassState& state) {
  const ClassId id = state.tracking.class_id;
  ClassId* const visited = visited_.data();
  const int up = neighbour_[0], right = neighbour_[1], down = neighbour_[2], left = neighbour_[3];
  // Drops stand on unmarked cells while shrinking, so unmark the boundary drops first.
  for (const CellIndex drop : state.boundary_drops)
    visited[drop] = kNoClass;
  int cells = state.cells - static_cast<int>(state.boundary_drops.size());
  int processed = 0;
  // The two lists as plain arrays with their sizes in registers (the byte stores into V would
  // make the compiler reload sizes kept in memory after each of them). Every cell is pushed at
  // most once (it is unmarked when pushed), so the room for every cell suffices.
  CellIndex* const drops = state.boundary_drops.data();
  std::size_t dropCount = state.boundary_drops.size();
  CellIndex* const stopped = state.work_drops.data();
  std::size_t stoppedCount = state.work_drops.size();
  auto moveInto = [&](CellIndex next) {
    if (visited[next] == id) {
      visited[next] = kNoClass;
      --cells;
      drops[dropCount++] = next;
    }
  };
  // Shrinking starts only at the boundary: a change deep inside a region that touches no
  // boundary drop (a ball jumping into green) is not seen here (seed 3.1.5); see
  // searchInsideParent for the remedy used for small, fast classes.
  while (dropCount > 0) {
    const CellIndex drop = drops[--dropCount];
    ++processed;
    const ClassId now = classOf(drop);
    if (now == id || now == kBlocked) {
      // Still the region's class (or a mask-edge cell not due this frame, kept until it is):
      // the drop stops here and will seed the growing.
      stopped[stoppedCount++] = drop;
      continue;
    }
    // The cell left the region: the drop moves into every still-marked neighbour.
    moveInto(drop + up);
    moveInto(drop + right);
    moveInto(drop + down);
    moveInto(drop + left);
  }
  state.boundary_drops.setSize(0);
  state.work_drops.setSize(stoppedCount);
  // The stopped drops belong to the region again.
  for (const CellIndex drop : state.work_drops)
    visited[drop] = id;
  state.cells = cells + static_cast<int>(stoppedCount);
  stats_.drops_processed += processed;
}

// Procedure 1: grow the regions of one class from their drops to their full extent, collecting
// the boundary drops for the next shrink and the boundary sides for contour extraction.
void RegionTracker::grow(ClassState& state) {
  const ClassId id = state.tracking.class_id;
  ClassId* const visited = visited_.data();
  const ClassId* const seedParent = seed_parent_.data();
  // The lists as plain arrays with their sizes in registers, as in shrink. A cell is claimed at
  // most once, and is a boundary drop at most once.
  CellIndex* const drops = state.work_drops.data();
  std::size_t dropCount = state.work_drops.size();
  CellIndex* const boundary = state.boundary_drops.data();
  std::size_t boundaryCount = state.boundary_drops.size();
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
        drops[dropCount++] = next;
        return false;
      }
      if (seedParent[nextClass] == id) {
        // An untracked region of a class seeded from this one's boundary (the ball next to
        // green): it grows when its class's turn comes.
        classes_[class_slot_[nextClass]].pending_seeds.push_back(next);
      }
    }
    // Another class, blocked, or unvisited of another class: a boundary side.
    return true;
  };
  auto boundarySide = [&](CellIndex drop, int offset, int side) {
    if (!spreadTo(drop + offset)) return 0;
    connectivity_.addBoundarySideAt(drop, side);
    return 1;
  };
  const int up = neighbour_[0], right = neighbour_[1], down = neighbour_[2], left = neighbour_[3];
  while (dropCount > 0) {
    const CellIndex drop = drops[--dropCount];
    ++processed;
    // Each side on the boundary goes straight into the connectivity grid; a drop with any such
    // side is a boundary drop. (One statement per side: the order of the sides is fixed.)
    int sides = boundarySide(drop, up, 0);
    sides += boundarySide(drop, right, 1);
    sides += boundarySide(drop, down, 2);
    sides += boundarySide(drop, left, 3);
    if (sides > 0) boundary[boundaryCount++] = drop;
  }
  state.work_drops.setSize(0);
  state.boundary_drops.setSize(boundaryCount);
  state.cells = cells;
  stats_.drops_processed += processed;
}

void RegionTracker::seedPending(ClassState& state) {
  for (const CellIndex seed : state.pending_seeds) {
    if (visited_[seed] == kNoClass && classOfDue(seed) == state.tracking.class_id) {
      claim(state, seed);
    }
  }
  state.pending_seeds.clear();
}

void RegionTracker::seedAtViewEdge(ClassState& state) {
  const std::size_t stride = static_cast<std::size_t>(state.tracking.view_edge_stride);
  for (std::size_t i = static_cast<std::size_t>(frame_count_) % stride; i < view_edge_.size();
       i += stride) {
    const CellIndex cell = view_edge_[i];
    if (visited_[cell] == kNoClass && classOfDue(cell) == state.tracking.class_id) {
      claim(state, cell);
    }
  }
}

// Against the blind spot: the lost class `child` may sit inside its parent's regions, on cells
// the parent still claims from earlier frames. Check a sparse, rotating subset of the parent's
// interior cells; a stale one becomes a boundary drop of the parent, so the coming shrink carves
// the island out and the parent's grow seeds `child` from the island's new boundary.
void RegionTracker::searchInsideParent(const ClassState& child) {
  ClassState* parent = stateOf(child.tracking.seed_from_boundary_of);
  if (parent == nullptr || parent->cells == 0) return;
  const ClassId parentId = parent->tracking.class_id;
  const int stride = child.tracking.search_inside_parent_stride;
  const int phase = static_cast<int>(frame_count_ % (stride * stride));
  for (int y = phase / stride; y < grid_.height; y += stride) {
    for (int x = phase % stride; x < grid_.width; x += stride) {
      const CellIndex cell = layout_.index(x, y);
      if (visited_[cell] != parentId) continue;
      // A cell on the region's edge is a boundary drop already: shrink checks it anyway (and a
      // cell must not be a drop twice).
      bool interior = true;
      for (const int offset : neighbour_)
        interior = interior && visited_[cell + offset] == parentId;
      if (interior && classOf(cell) != parentId) parent->boundary_drops.push(cell);
    }
  }
}

// Seed 3.1.7: measure every untracked region of the class in the whole frame and seed the
// largest ones with one drop each.
void RegionTracker::initialSearch(ClassState& state) {
  const ClassId id = state.tracking.class_id;
  seed_candidates_.clear();
  for (int y = 0; y < grid_.height; ++y) {
    for (int x = 0; x < grid_.width; ++x) {
      const CellIndex start = layout_.index(x, y);
      if (scratch_mark_[start] || visited_[start] != kNoClass || classOfDue(start) != id) continue;
      // Flood the region on the scratch marks to measure its size.
      int size = 0;
      scratch_mark_[start] = 1;
      scratch_queue_.push_back(start);
      while (!scratch_queue_.empty()) {
        const CellIndex cell = scratch_queue_.back();
        scratch_queue_.pop_back();
        ++size;
        for (const int offset : neighbour_) {
          const CellIndex next = cell + offset;
          if (!scratch_mark_[next] && visited_[next] == kNoClass && classOfDue(next) == id) {
            scratch_mark_[next] = 1;
            scratch_queue_.push_back(next);
          }
        }
      }
      if (size >= state.tracking.min_seed_cells) seed_candidates_.push_back({size, start});
    }
  }
  std::fill(scratch_mark_.begin(), scratch_mark_.end(), 0);

  // Every candidate, or (with a cap) the largest ones.
  std::size_t seeds = seed_candidates_.size();
  if (state.tracking.max_seed_regions > 0 &&
      seeds > static_cast<std::size_t>(state.tracking.max_seed_regions)) {
    seeds = static_cast<std::size_t>(state.tracking.max_seed_regions);
    std::partial_sort(
        seed_candidates_.begin(), seed_candidates_.begin() + seeds, seed_candidates_.end(),
        [](const SeedCandidate& a, const SeedCandidate& b) { return a.cells > b.cells; });
  }
  for (std::size_t i = 0; i < seeds; ++i)
    claim(state, seed_candidates_[i].seed);
}

int RegionTracker::dropRegion(ClassId class_id, int x, int y) {
  ClassState* state = stateOf(class_id);
  if (state == nullptr || !grid_.contains(x, y)) return 0;
  const CellIndex start = layout_.index(x, y);
  if (visited_[start] != class_id) return 0;
  // Shrinking without a stopping criterion: unmark the whole connected region.
  int released = 0;
  visited_[start] = kNoClass;
  scratch_queue_.push_back(start);
  while (!scratch_queue_.empty()) {
    const CellIndex cell = scratch_queue_.back();
    scratch_queue_.pop_back();
    ++released;
    for (const int offset : neighbour_) {
      const CellIndex next = cell + offset;
      if (visited_[next] == class_id) {
        visited_[next] = kNoClass;
        scratch_queue_.push_back(next);
      }
    }
  }
  state->cells -= released;
  // Its boundary drops must go too, or the next shrink would revive the region.
  std::size_t kept = 0;
  CellIndex* const drops = state->boundary_drops.data();
  for (std::size_t i = 0; i < state->boundary_drops.size(); ++i) {
    if (visited_[drops[i]] == class_id) drops[kept++] = drops[i];
  }
  state->boundary_drops.setSize(kept);
  return released;
}

void RegionTracker::dropClass(ClassId class_id) {
  ClassState* state = stateOf(class_id);
  if (state == nullptr) return;
  std::replace(visited_.begin(), visited_.end(), class_id, kNoClass);
  state->work_drops.clear();
  state->boundary_drops.clear();
  state->pending_seeds.clear();
  state->cells = 0;
}

void RegionTracker::addSeed(ClassId class_id, int x, int y) {
  ClassState* state = stateOf(class_id);
  if (state == nullptr) {
    throw std::invalid_argument("region tracker: seed for untracked class " +
                                std::to_string(class_id));
  }
  if (!grid_.contains(x, y)) throw std::out_of_range("region tracker: seed outside the grid");
  state->pending_seeds.push_back(layout_.index(x, y));
}

void RegionTracker::reinitialise() {
  visited_ = empty_visited_;
  for (ClassState& state : classes_) {
    state.work_drops.clear();
    state.boundary_drops.clear();
    state.cells = 0;
  }
}

}  // namespace fieldline::region_tracking
