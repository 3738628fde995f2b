// Where a binary finds the data shipped with it, without a compiled-in path: an installed tree
// works wherever its prefix is, a build tree has the same shape.
//   installed:  <prefix>/bin/fieldline-x  ->  <prefix>/share/fieldline/{config,web,...}
//   build tree: build/bin/fieldline-x     ->  build/share/fieldline/{config,web,...}, symlinks
//               into the source tree made by CMake (fieldline_data_directory,
//               cmake/Fieldline.cmake)
// config::projectRoot() (config.hpp), which preset names resolve against, is FIELDLINE_ROOT when
// set (a source tree or any folder with config/), else dataDirectory().
// Paths named inside config files resolve against the file that names them (issue 30): a camera
// preset and the colour table beside it can move together, wherever the tool was started.
#pragma once

#include <string>

namespace fieldline::config {

// A name or path given inside a config file (e.g. a camera preset's `colour_table:`): a relative
// path (a value containing '/' or ending in .yaml, or any value when `category` is empty) is
// resolved against the folder of `naming_file`; an absolute path is kept; a bare name is a
// preset of `category` and returned as it is (the loader resolves it with resolvePreset, which
// also knows an installed prefix). The result is what a loadXPreset(name_or_path) takes.
std::string resolveAgainst(const std::string& naming_file, const std::string& category,
                           const std::string& value);

// The data folder relative to the binaries' folder.
inline constexpr const char* kDataSubdirectory = "share/fieldline";

// The folder of the running executable (from /proc/self/exe), empty if unknown.
std::string executableDirectory();

// `<executableDirectory()>/../share/fieldline`: config/ (presets, launch files), web/ (the
// viewer's page), systemd/ (the units' environment files), java/ (lcm-spy's types).
std::string dataDirectory();

}  // namespace fieldline::config
