// team_state_t (TEAM_STATE) <-> perception::TeamState. header.utime <-> utime; num_robots is
// always kTeamSize.
#pragma once

#include <fieldline/team_state_t.hpp>

#include "common/perception/team.hpp"

namespace fieldline::msg {

// Arrays shorter than kTeamSize leave the missing robots absent; longer ones are cut.
perception::TeamState fromMessage(const team_state_t& m);
void toMessage(const perception::TeamState& s, team_state_t& m);

}  // namespace fieldline::msg
