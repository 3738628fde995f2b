// The test executables' precompiled header (cmake/Fieldline.cmake, FIELDLINE_PCH): the third-party
// and standard headers most test files parse, compiled once per build. Only headers whose meaning
// does not depend on a target's own definitions (FMT_SHARED, SPDLOG_*, ...) belong here: the tests
// are compiled with -Winvalid-pch, so a mismatch fails the build instead of silently parsing
// everything again.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>
#include <Eigen/Core>
