// The team's shared secret for the packet MAC: 32 bytes, stored as 64 hex digits in a text file
// ('#' comment lines allowed). `fieldline-team-key --out FILE` makes a new one.
#pragma once

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace fieldline::teamcomm {

class KeyError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct TeamKey {
  std::array<std::uint8_t, 32> bytes{};
};

// Reads a key file; throws KeyError naming the file and what is wrong.
TeamKey loadTeamKey(const std::string& path);
// Parses the text of a key file (`name` stands for the file in messages).
TeamKey parseTeamKey(const std::string& text, const std::string& name);
// A fresh random key (libsodium's CSPRNG).
TeamKey generateTeamKey();
// The file text for a key, with a comment header.
std::string formatTeamKey(const TeamKey& key, const std::string& comment);

}  // namespace fieldline::teamcomm
