// JSON and CSV for every fieldline message type: every field by name, arrays as JSON arrays. The
// writers are generated from lcmtypes/*.lcm at build time (gen_message_writers.py), so a new field
// cannot be forgotten. Used by fieldline-bus-dump.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace fieldline::bus_dump {

struct JsonOptions {
  // Write image_t pixel bytes as a JSON array instead of their size and FNV-1a hash.
  bool image_data = false;
};

// FNV-1a, 64 bit, of `size` bytes: the summary of image data.
std::uint64_t fnv1a64(const std::uint8_t* data, std::size_t size);

// Decodes `data` as the type `channel` carries (channels.hpp) and appends the message as a JSON
// object. The caller has already checked the event (bus::checkEncoded); returns false if the
// channel is unknown or the bytes do not decode.
bool appendMessageJson(std::string& out, std::string_view channel, const void* data, int size,
                       const JsonOptions& options);

// The CSV header line of `channel` (without the line break): log_utime, then one column per
// field (header.utime, ..., ticks[0], ticks[1], ...; a variable-length array is one column
// holding a JSON array). False for an unknown channel.
bool appendCsvHeader(std::string& out, std::string_view channel);
// One CSV row (without the line break) of a checked message; false if it does not decode.
bool appendCsvRow(std::string& out, std::string_view channel, std::int64_t log_utime,
                  const void* data, int size, const JsonOptions& options);

}  // namespace fieldline::bus_dump
