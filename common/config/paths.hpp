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

}  // namespace fieldline::config
