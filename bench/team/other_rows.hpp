// fieldline-team-ball-replay --others: every robot the team ball did not use in a scored
// picture, why, where it is and what it knew (docs/teamcomm.md "Team ball").
#pragma once

#include <cstdio>
#include <map>
#include <vector>

#include <Eigen/Core>

#include "bench/team/robot_log.hpp"
#include "bench/team/sighting_rows.hpp"
#include "common/perception/team.hpp"
#include "teamcomm/team_picture.hpp"
#include "tools/eval/evaluation.hpp"

namespace fieldline::team_bench {

// The CSV header of --others.
const char* otherRowsHeader();

// Every robot the team ball did not use in a scored picture: why, where it is, when its camera
// last saw a ball and how good its own newest valid estimate (held to now) is.
void writeOtherRows(std::FILE* others_csv, const std::vector<eval::TruthSample>& truth,
                    const std::map<int, RobotLog>& logs, int observer, Utime now, Utime start,
                    const Eigen::Vector2d& t, const teamcomm::TeamBallResult& result,
                    const perception::TeamState& state, const teamcomm::TeamPicture& picture,
                    const teamcomm::PictureOptions& options, const SightingRows& bodies);

}  // namespace fieldline::team_bench
