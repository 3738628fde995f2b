// Where a binary finds the data shipped with it, without a compiled-in path: an installed tree
// works wherever its prefix is, a build tree has the same shape.
//   installed:  <prefix>/bin/fieldline-x  ->  <prefix>/share/fieldline/{config,web,...}
//   build tree: build/bin/fieldline-x     ->  build/share/fieldline/{config,web,...}, symlinks
//               into the source tree made by CMake (fieldline_data_directory,
//               cmake/Fieldline.cmake)
// config::projectRoot() (config.hpp), which preset names resolve against, is FIELDLINE_ROOT when
// set (a source tree or any folder with config/), else dataDirectory().
#pragma once

#include <string>

namespace fieldline::config {

// The data folder relative to the binaries' folder.
inline constexpr const char* kDataSubdirectory = "share/fieldline";

// The folder of the running executable (from /proc/self/exe), empty if unknown.
std::string executableDirectory();

// `<executableDirectory()>/../share/fieldline`: config/ (presets, launch files), web/ (the
// viewer's page), systemd/ (the units' environment files), java/ (lcm-spy's types).
std::string dataDirectory();

}  // namespace fieldline::config
