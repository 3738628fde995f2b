// odometry_t (ODOMETRY) <-> perception::OdometryReading. header.utime <-> utime.
#pragma once

#include <fieldline/odometry_t.hpp>

#include "common/perception/body.hpp"

namespace fieldline::msg {

perception::OdometryReading fromMessage(const odometry_t& m);
void toMessage(const perception::OdometryReading& r, odometry_t& m);

}  // namespace fieldline::msg
