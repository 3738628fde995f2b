// Detectors that run on the region boundaries (seed 3.3): field lines along the normals of the
// green boundaries, the ball in orange regions next to green, obstacles in black regions next
// to green. They read single pixels of the raw frame and map image points to the robot frame
// through the mirror model. One header per detector; this one includes them all.
#pragma once

#include "services/region_tracking/ball_detector.hpp"
#include "services/region_tracking/floor_lookup.hpp"
#include "services/region_tracking/line_detector.hpp"
#include "services/region_tracking/obstacle_detector.hpp"
