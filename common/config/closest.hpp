// "Did you mean ...": the closest of a set of valid names to a misspelt one, for config keys,
// executables and presets.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace fieldline::config {

// Edit distance with adjacent transpositions (optimal string alignment): "restrat" ->
// "restart" is 1.
std::size_t editDistance(const std::string& a, const std::string& b);

// The candidate closest to `word` if it is a plausible misspelling of it (distance 1 for words
// of up to 4 characters, 2 for longer ones), else "".
std::string closestMatch(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace fieldline::config
