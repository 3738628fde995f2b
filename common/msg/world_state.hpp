// world_state_t (SIM_WORLD) <-> perception::WorldTruth. header.utime <-> utime.
#pragma once

#include <fieldline/world_state_t.hpp>

#include "common/perception/world_truth.hpp"

namespace fieldline::msg {

// The message is validated by the bus (array sizes agree with the counts) before this runs.
perception::WorldTruth fromMessage(const world_state_t& m);
// Reuses m's arrays (no allocation once they have grown).
void toMessage(const perception::WorldTruth& w, world_state_t& m);

}  // namespace fieldline::msg
