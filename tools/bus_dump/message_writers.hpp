// The pieces the generated writers (gen_message_writers.py) are made of: one JSON value writer
// per LCM field type, arrays, byte arrays as a hash, and CSV cells.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "common/bus/channels.hpp"
#include "tools/bus_dump/message_json.hpp"
#include "tools/json/json_text.hpp"

namespace fieldline::bus_dump::generated {

inline void appendValue(std::string& out, std::int8_t v) {
  out += std::to_string(int{v});
}
inline void appendValue(std::string& out, std::uint8_t v) {
  out += std::to_string(unsigned{v});
}
inline void appendValue(std::string& out, std::int16_t v) {
  out += std::to_string(v);
}
inline void appendValue(std::string& out, std::int32_t v) {
  out += std::to_string(v);
}
inline void appendValue(std::string& out, std::int64_t v) {
  out += std::to_string(v);
}
// Validated messages have no NaN or infinity, but a writer must not emit invalid JSON if one
// slips through: json::appendNumber writes null.
inline void appendValue(std::string& out, float v) {
  json::appendNumber(out, v);
}
inline void appendValue(std::string& out, double v) {
  json::appendNumber(out, v);
}
inline void appendValue(std::string& out, const std::string& v) {
  json::appendString(out, v);
}

template <typename T>
void appendValues(std::string& out, const T* values, std::size_t count) {
  out += '[';
  for (std::size_t i = 0; i < count; ++i) {
    if (i > 0) out += ',';
    appendValue(out, values[i]);
  }
  out += ']';
}
template <typename T>
void appendArray(std::string& out, const std::vector<T>& values) {
  appendValues(out, values.data(), values.size());
}
template <typename T, std::size_t N>
void appendArray(std::string& out, const T (&values)[N]) {
  appendValues(out, values, N);
}
// LCM's boolean is an int8_t in C++; JSON gets true/false.
template <typename Booleans>
void appendBoolArray(std::string& out, const Booleans& values) {
  out += '[';
  bool first = true;
  for (const auto v : values) {
    if (!first) out += ',';
    first = false;
    out += v ? "true" : "false";
  }
  out += ']';
}
// Bytes (image pixels) would swamp the output; the hash says whether two are the same.
template <typename Bytes>
void appendHash(std::string& out, const Bytes& bytes) {
  out += fmt::format("\"{:016x}\"", fnv1a64(reinterpret_cast<const std::uint8_t*>(&bytes[0]),
                                            static_cast<std::size_t>(std::size(bytes))));
}
// A CSV cell: quoted when it holds a comma, a quote or a line break, quotes doubled.
inline void appendCsvString(std::string& out, std::string_view text) {
  if (text.find_first_of(",\"\n\r") == std::string_view::npos) {
    out += text;
    return;
  }
  out += '"';
  for (const char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  out += '"';
}

}  // namespace fieldline::bus_dump::generated
