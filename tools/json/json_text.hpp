// Writing JSON text by hand, in one place for every tool that prints or serves JSON: strings
// escaped and always valid UTF-8, numbers that read back to the same value (non-finite ones as
// null, which JSON has no other word for), and an object writer that puts the commas in.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace fieldline::json {

// Appends `text` as a JSON string literal: quotes, backslashes and control characters escaped,
// invalid UTF-8 replaced by U+FFFD byte by byte.
void appendString(std::string& out, std::string_view text);
// Shortest form that parses back to the same value; NaN and infinities become null.
void appendNumber(std::string& out, double value);
void appendNumber(std::string& out, float value);

// A JSON object under construction, {"a":1,"b":[...]}; closed when destroyed. Nested objects
// write into key(): `Object inner(outer.key("frame"));`.
class Object {
 public:
  explicit Object(std::string& out) : out_(out) { out_ += '{'; }
  ~Object() { out_ += '}'; }
  Object(const Object&) = delete;
  Object& operator=(const Object&) = delete;

  // Starts a member and returns the output for its value.
  std::string& key(std::string_view name);

  void number(std::string_view name, double value) { appendNumber(key(name), value); }
  void integer(std::string_view name, std::int64_t value) { key(name) += std::to_string(value); }
  void boolean(std::string_view name, bool value) { key(name) += value ? "true" : "false"; }
  void string(std::string_view name, std::string_view value) { appendString(key(name), value); }
  // An array of numbers, each written as a double.
  template <typename T>
  void numbers(std::string_view name, const T* values, std::size_t count) {
    std::string& out = key(name);
    out += '[';
    for (std::size_t i = 0; i < count; ++i) {
      if (i > 0) out += ',';
      appendNumber(out, static_cast<double>(values[i]));
    }
    out += ']';
  }

 private:
  std::string& out_;
  bool first_ = true;
};

}  // namespace fieldline::json
