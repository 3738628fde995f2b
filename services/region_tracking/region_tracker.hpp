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

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "services/region_tracking/cell_grid.hpp"
#include "services/region_tracking/contours.hpp"

namespace fieldline::config {
class Node;
}

namespace fieldline::region_tracking {

// How one colour class is tracked.
struct ClassTracking {
  ClassId class_id = 0;
  // When the class has no region left, search the whole frame for its largest regions (seed
  // 3.1.7). Costs a full pass over the frame in every frame the class stays absent.
  bool search_when_lost = true;
  // An initial search seeds every region of at least min_seed_cells cells; with
  // max_seed_regions > 0 only that many of the largest (the seed uses 10, which misses the small
  // regions inside the penalty and goal areas when more than ten are in view). 0: no cap.
  int max_seed_regions = 0;
  int min_seed_cells = 4;
  // Extension to the seed: every frame, unvisited cells of this class next to the boundary of
  // the regions of class `seed_from_boundary_of` become seeds (e.g. the ball next to green). The
  // parent must come earlier in the class list. kNoClass: off.
  ClassId seed_from_boundary_of = kNoClass;
  // Extension to the seed: untracked cells of this class on the edge of the view (next to the
  // don't-touch mask or the grid's border) become seeds, so regions that move into view are
  // tracked within a few frames instead of at the next re-initialisation. Each frame looks at
  // every n-th edge cell, starting one further each frame (all of them every n frames);
  // 0: off.
  int view_edge_stride = 0;
  // Extension to the seed, against its blind spot (3.1.5): shrinking starts only at boundary
  // drops, so a small region that jumps (a fast ball) lands inside its parent's region, whose
  // stale cells are never looked at again, and is lost until the next re-initialisation. For
  // 2*n*n frames after this class lost its last region, every n-th cell of the parent's region
  // interiors (a rotating pattern, all of them every n*n frames) is checked; a cell that lost
  // the parent's class is handed to the parent's shrink, which carves the stale island out, and
  // the class is seeded from its boundary again. (A class that has been away longer left the
  // view: it comes back across a boundary.) Needs seed_from_boundary_of; 0: off.
  int search_inside_parent_stride = 0;
};

struct TrackerConfig {
  // Pixels per cell side: 1, 2, 4 or 8.
  int cell_size = 4;
  // Classes in processing order; class ids must be distinct and below 254 (254 and 255 are
  // reserved).
  std::vector<ClassTracking> classes;
  // Forget everything and search again every this many frames (0: never; the seed uses 300).
  int reinitialise_period_frames = 300;
  // Bounded staleness at the edge of the view (not in the seed). Cells next to the don't-touch
  // mask are on every region's boundary, so an exact tracker classifies them every frame; with
  // n > 1 each is classified only every n-th frame, in interleaved sets ((x + y) mod n against
  // the frame counter), so a change there is seen at most n - 1 frames late. 1: every frame
  // (exact). Applies to the outer rim (cells next to the mask around the mirror's edge or the
  // grid's border: the far field) and, with mask_edge_inner, also to the inner edge (next to the
  // robot's own body in the image centre: the near field).
  int mask_edge_every = 1;
  bool mask_edge_inner = false;
};

// Where a touchable cell meets the don't-touch mask.
enum class MaskEdge : std::uint8_t {
  kNone,   // no blocked neighbour
  kOuter,  // next to a blocked cell connected to the outside of the grid (the mirror's rim)
  kInner,  // next only to blocked cells enclosed by touchable ones (the robot's body)
};
// One entry per cell, row-major. Blocked cells are connected through their 8 neighbours; the
// outside of the grid is blocked. `dontTouch`: one byte per cell or empty (nothing blocked).
std::vector<MaskEdge> maskEdges(const CellGrid& grid, std::span<const std::uint8_t> dontTouch);
// 4-connected steps of every cell from the nearest kOuter cell of `edges` (0 on the rim, -1 where
// no rim cell is reachable): tells a change at the rim from one further in (the rim cadence).
std::vector<int> stepsFromOuterRim(const CellGrid& grid, const std::vector<MaskEdge>& edges);

// Reads keys cell_size, reinitialise_period_frames, mask_edge_every, mask_edge_inner (both
// optional) and a list `classes` of maps {class,
// search_when_lost, max_seed_regions, min_seed_cells, seed_from_boundary_of, view_edge_stride,
// search_inside_parent_stride}
// (all but class optional, defaults as in ClassTracking); class names are
// turned into ids by `classByName` (nullopt: "unknown class" error at that key).
TrackerConfig loadTrackerConfig(
    const config::Node& node,
    const std::function<std::optional<ClassId>(const std::string&)>& classByName);

// Why a cell was classified (each cell is classified at most once per frame, for the first
// reason that needs it).
enum class TouchReason : std::uint8_t {
  kShrink,         // a shrinking drop checks whether its cell still has the class
  kGrow,           // a growing drop looks at an unvisited neighbour
  kSeed,           // seeds handed in or found next to a parent class's boundary
  kViewEdge,       // seeding at the edge of the view
  kInitialSearch,  // the whole-frame search of a lost class
  kInsideParent,   // the sparse check of a parent's interior for a lost class
};
inline constexpr int kTouchReasonCount = 6;

// What one track() call did: the quantities of the seed's table 3.1.
struct TrackingStats {
  std::int64_t frame = 0;
  // Distinct cells whose class was computed in this frame (each at most once).
  int cells_classified = 0;
  // cells_classified split by TouchReason.
  std::array<int, kTouchReasonCount> classified_by{};
  // cells_classified / cells in the grid: the fraction of the image accessed.
  double touched_fraction = 0.0;
  // Drops taken from the queues by shrink and grow together.
  int drops_processed = 0;
  // Cells of all tracked regions at the end of the previous frame, after shrinking to the new
  // frame (the overlap), and after growing.
  int cells_before = 0;
  int cells_after_shrink = 0;
  int cells_after_grow = 0;
  // cells_after_shrink / cells_after_grow: the share of this frame's regions carried over (1 when
  // nothing moved, 0 after an initial search).
  double overlap = 0.0;
  // Classes that had to be searched for in the whole frame.
  int initial_searches = 0;
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

  // Stops tracking the region of `class_id` containing cell (x, y) (shrinking without a stopping
  // criterion). Returns the number of cells released; 0 if the cell is not in such a region.
  int dropRegion(ClassId class_id, int x, int y);
  // Stops tracking every region of a class.
  void dropClass(ClassId class_id);
  // Adds a seed cell for a class, grown on the next track() if the cell then has the class.
  void addSeed(ClassId class_id, int x, int y);
  // Forgets all regions; the next track() starts from initial searches.
  void reinitialise();

  const CellGrid& grid() const { return grid_; }
  const TrackerConfig& config() const { return config_; }
  // The class owning cell (x, y): kNoClass where no tracked region is (and in don't-touch
  // cells).
  ClassId ownerOf(int x, int y) const {
    const ClassId owner = visited_[layout_.index(x, y)];
    return owner == kBlocked ? kNoClass : owner;
  }
  // ownerOf for every cell, row-major (a copy, for comparisons and drawings).
  std::vector<ClassId> visited() const;
  // Boundaries of all tracked regions after the last track().
  const ContourSet& contours() const { return contours_; }
  // Cells of a class's regions after the last track().
  int regionCells(ClassId class_id) const;
  const TrackingStats& stats() const { return stats_; }
  // True if the last track() computed the class of cell (x, y): the cells it accessed.
  bool classifiedInLastFrame(int x, int y) const {
    // Stamps start at 1 with the first frame: before it, no cell was classified.
    // (A deferred mask-edge cell carries the stamp with class kBlocked: not classified.)
    const std::uint16_t entry = classified_[layout_.index(x, y)];
    return frame_count_ > 0 && (entry >> 8) == stamp_ && (entry & 0xFF) != kBlocked;
  }

 private:
  // In V: outside the grid or don't-touch. Never a tracked class.
  static constexpr ClassId kBlocked = 0xFE;
  // Cells are padded indices (PaddedLayout): the frame of kBlocked cells around the grid
  // spares every bounds check when a drop looks at its neighbours.
  using CellIndex = std::int32_t;

  // A list of cells, used as a stack, with room for every cell of the grid allocated once, so a
  // push needs no capacity check: a cell is on one of a class's drop lists at most once.
  class DropList {
   public:
    void allocate(std::size_t capacity) { cells_.resize(capacity); }
    void push(CellIndex cell) { cells_[size_++] = cell; }
    CellIndex pop() { return cells_[--size_]; }
    bool empty() const { return size_ == 0; }
    void clear() { size_ = 0; }
    const CellIndex* begin() const { return cells_.data(); }
    const CellIndex* end() const { return cells_.data() + size_; }
    operator std::span<const CellIndex>() const { return {begin(), size_}; }
    // For the hot loops, which keep the top of the stack in a register: the cells, and setting
    // the size they leave.
    CellIndex* data() { return cells_.data(); }
    std::size_t size() const { return size_; }
    void setSize(std::size_t size) { size_ = size; }

   private:
    std::vector<CellIndex> cells_;
    std::size_t size_ = 0;
  };

  // Per class: the pair of drop lists (used as stacks; order does not matter) and its size.
  struct ClassState {
    ClassTracking tracking;
    // Kept from frame to frame: the boundary cells of the regions. Filled by grow, emptied by the
    // next shrink, which starts from them.
    DropList boundary_drops;
    // Within one frame: the drops still to spread. Filled by shrink (the drops that stopped) and
    // by seeding, emptied by grow.
    DropList work_drops;
    std::vector<CellIndex> pending_seeds;
    int cells = 0;
    // Frames since the class last had a region (a large number before it was ever seen).
    int frames_lost = kNeverSeen;
  };
  static constexpr int kNeverSeen = 1 << 30;

  // The class of a cell in the current frame, computed at most once per frame. kBlocked for a
  // mask-edge cell not due this frame (mask_edge_every): shrink keeps it, grow does not enter it.
  ClassId classOf(CellIndex cell) {
    const std::uint32_t entry = classified_[cell];
    if ((entry >> 8) == stamp_) return static_cast<ClassId>(entry & 0xFF);
    return classifyNow(cell);
  }
  // Inlined into the hot loops: the call would add a frame to the classifier's own.
  [[gnu::always_inline]] ClassId classifyNow(CellIndex cell) {
    const Cell at = coordinatesOf(cell);
    const ClassId class_id = classifier_->classify(at.x, at.y);
    classified_[cell] = static_cast<std::uint16_t>((stamp_ << 8) | class_id);
    ++stats_.cells_classified;
    return class_id;
  }
  // classOf, but a deferred mask-edge cell is classified all the same (seeding, initial search).
  ClassId classOfDue(CellIndex cell) {
    const ClassId class_id = classOf(cell);
    return class_id == kBlocked ? classifyNow(cell) : class_id;
  }
  // Marks the mask-edge cells not due this frame as classified, with class kBlocked.
  void deferMaskEdge();
  // From now on cells are classified for `reason` (books the cells since the last call).
  void touchFor(TouchReason reason);
  ClassState* stateOf(ClassId class_id);
  // Marks an unvisited cell as the class's and queues it as a growing drop.
  void claim(ClassState& state, CellIndex cell) {
    visited_[cell] = state.tracking.class_id;
    ++state.cells;
    state.work_drops.push(cell);
  }

  // The i-th class of the config: a free id, sound seed limits, listed once, seeded from the
  // boundary of a class listed before it (when it is).
  static void checkClass(const TrackerConfig& config, std::size_t i);
  // Construction: a class's state (with its worst-case buffers), the view's edge cells, the
  // mask-edge cells under the cadence.
  void addClass(const ClassTracking& tracking);
  void findViewEdge();
  void findDeferrableCells(const std::vector<std::uint8_t>& dontTouch);

  void shrink(ClassState& state);
  void grow(ClassState& state);
  void seedPending(ClassState& state);
  void seedAtViewEdge(ClassState& state);
  void initialSearch(ClassState& state);
  void searchInsideParent(const ClassState& child);

  CellGrid grid_;
  PaddedLayout layout_;
  int neighbour_[4];  // index offsets up, right, down, left
  TrackerConfig config_;
  std::vector<ClassId> visited_;        // V, padded
  std::vector<ClassId> empty_visited_;  // V with nothing tracked: kBlocked frame and mask only
  std::vector<ClassState> classes_;
  // Touchable cells with a don't-touch or out-of-grid neighbour: where new content enters.
  std::vector<CellIndex> view_edge_;
  // The mask-edge cells under the cadence (mask_edge_every > 1) and their phase, (x + y) mod n:
  // a cell is due in the frames whose counter mod n equals its phase.
  struct DeferrableCell {
    CellIndex cell;
    int phase;
  };
  std::vector<DeferrableCell> deferrable_;
  // By class id: index into classes_, and the class whose boundary seeds it (kNoClass: none).
  std::array<int, 256> class_slot_;
  std::array<ClassId, 256> seed_parent_;
  ConnectivityGrid connectivity_;
  ContourSet contours_;

  // Per-frame cache of classifications, 16 bits per cell: the frame's stamp (high byte) and the
  // class (low byte); valid while the stamp is the frame's. One load answers both questions. (16
  // bits keep the cache of a 640x480 frame's grid at 40 kB; the stamp wraps every 255 frames,
  // when the cache is cleared.)
  const CellClassifier* classifier_ = nullptr;
  // Why the cells classified now are classified; stats_.cells_classified when it was set.
  TouchReason touch_reason_ = TouchReason::kShrink;
  int reason_start_ = 0;
  std::vector<std::uint16_t> classified_;
  std::uint32_t stamp_ = 0;
  static constexpr std::uint32_t kStampLimit = 1u << 8;
  // The classifier takes grid coordinates: the layout's pitch is a power of two, so x and y of a
  // padded index are a mask and a shift (no division per cell, no table of coordinates).
  Cell coordinatesOf(CellIndex cell) const {
    const auto index = static_cast<std::uint32_t>(cell);
    return {static_cast<std::int16_t>((index & static_cast<std::uint32_t>(layout_.width - 1)) - 1),
            static_cast<std::int16_t>((index >> layout_.pitch_shift) - 1)};
  }

  // Scratch for initial searches and dropRegion, kept to avoid per-frame allocation.
  std::vector<CellIndex> scratch_queue_;
  std::vector<std::uint8_t> scratch_mark_;
  struct SeedCandidate {
    int cells;
    CellIndex seed;
  };
  std::vector<SeedCandidate> seed_candidates_;

  std::int64_t frame_count_ = 0;
  TrackingStats stats_;
};

}  // namespace fieldline::region_tracking
