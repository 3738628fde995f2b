#include "teamcomm/team_key.hpp"

#include <sodium.h>

#include <fstream>
#include <sstream>

namespace fieldline::teamcomm {
namespace {

int hexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

TeamKey parseTeamKey(const std::string& text, const std::string& name) {
  std::istringstream in(text);
  std::string line;
  std::string hex;
  int line_number = 0;
  int key_line = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto last = line.find_last_not_of(" \t\r");
    if (key_line != 0) {
      throw KeyError(name + ":" + std::to_string(line_number) +
                     ": more than one key line (the key is one line of 64 hex digits)");
    }
    key_line = line_number;
    hex = line.substr(first, last - first + 1);
  }
  if (key_line == 0) throw KeyError(name + ": no key (expected one line of 64 hex digits)");
  const std::string where = name + ":" + std::to_string(key_line);
  if (hex.size() != 64) {
    throw KeyError(where + ": key has " + std::to_string(hex.size()) +
                   " characters, expected 64 hex digits (32 bytes)");
  }
  TeamKey key;
  for (std::size_t i = 0; i < key.bytes.size(); ++i) {
    const int hi = hexValue(hex[2 * i]);
    const int lo = hexValue(hex[2 * i + 1]);
    if (hi < 0 || lo < 0) throw KeyError(where + ": key contains a non-hex character");
    key.bytes[i] = static_cast<std::uint8_t>(hi * 16 + lo);
  }
  return key;
}

TeamKey loadTeamKey(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw KeyError(path + ": cannot read the team key file");
  std::ostringstream text;
  text << in.rdbuf();
  return parseTeamKey(text.str(), path);
}

TeamKey generateTeamKey() {
  if (sodium_init() < 0) throw KeyError("libsodium failed to initialise");
  TeamKey key;
  crypto_auth_keygen(key.bytes.data());
  return key;
}

std::string formatTeamKey(const TeamKey& key, const std::string& comment) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  std::istringstream lines(comment);
  std::string line;
  while (std::getline(lines, line))
    out += "# " + line + "\n";
  for (std::uint8_t b : key.bytes) {
    out += kHex[b >> 4];
    out += kHex[b & 15];
  }
  out += "\n";
  return out;
}

}  // namespace fieldline::teamcomm
