// A hash of what the region tracker and the line detector output, frame after frame: equal
// before and after a change meant to keep the outputs (a speed change). Used by
// fieldline-profile-tracking --digest and the line detector's digest test.
#pragma once

#include <bit>
#include <cstdint>

#include "services/region_tracking/detectors.hpp"
#include "services/region_tracking/region_tracker.hpp"

namespace fieldline::region_tracking {

// FNV-1a over the tracker's outputs of every frame: which class owns each cell, the contours
// (class, kind, area, every point in order) and the counts of TrackingStats; and over the line
// points (every position bit for bit, the sequences).
class OutputDigest {
 public:
  void add(const RegionTracker& tracker) {
    const CellGrid& grid = tracker.grid();
    for (int y = 0; y < grid.height; ++y) {
      for (int x = 0; x < grid.width; ++x)
        mix(tracker.ownerOf(x, y));
    }
    const ContourSet& contours = tracker.contours();
    for (const Contour& c : contours.contours) {
      mix(c.class_id);
      mix(c.outer ? 1 : 0);
      mix(c.signed_cell_area);
      for (const ContourPoint& p : contours.pointsOf(c)) {
        mix(p.x);
        mix(p.y);
      }
    }
    const TrackingStats& s = tracker.stats();
    mix(s.cells_classified);
    for (const int n : s.classified_by)
      mix(n);
    mix(s.drops_processed);
    mix(s.cells_before);
    mix(s.cells_after_shrink);
    mix(s.cells_after_grow);
    mix(s.initial_searches);
    mix(s.contours);
  }
  // The line points of a frame: every position bit for bit, and the sequences.
  void add(const LinePoints& lines) {
    mix(static_cast<std::int64_t>(lines.points.size()));
    for (const LinePoint& p : lines.points) {
      for (const float f : {p.u, p.v, p.x, p.y})
        mix(std::bit_cast<std::uint32_t>(f));
    }
    mix(static_cast<std::int64_t>(lines.sequences.size()));
    for (const auto& [begin, end] : lines.sequences) {
      mix(begin);
      mix(end);
    }
  }
  std::uint64_t value() const { return hash_; }

 private:
  void mix(std::int64_t v) {
    for (int i = 0; i < 8; ++i) {
      hash_ = (hash_ ^ static_cast<std::uint8_t>(v >> (8 * i))) * 0x100000001b3ULL;
    }
  }
  std::uint64_t hash_ = 0xcbf29ce484222325ULL;
};

}  // namespace fieldline::region_tracking
