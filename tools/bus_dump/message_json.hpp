// JSON for every fieldline message type: one writer per type, every field by name, arrays as
// JSON arrays. Used by fieldline-bus-dump; the only place that knows the field lists.
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

}  // namespace fieldline::bus_dump
