// Fuzzes the YAML config loader (common/config): any text must either load or fail with
// config::Error, and so must every typed read of every key in it.
#include <cstddef>
#include <cstdint>
#include <string>

#include "common/config/config.hpp"

namespace config = fieldline::config;

namespace {

// Reads every key of a map as each scalar type the loaders use, and recurses into sections.
void readEverything(const config::Node& node, int depth) {
  if (depth > 16 || !node.yaml().IsMap()) return;
  for (const std::string& key : node.keys()) {
    try {
      (void)node.get<double>(key, -1e9, 1e9);
    } catch (const config::Error&) {
    }
    try {
      (void)node.getOr<int>(key, 0);
    } catch (const config::Error&) {
    }
    try {
      (void)node.get<bool>(key);
    } catch (const config::Error&) {
    }
    try {
      (void)node.get<std::string>(key);
    } catch (const config::Error&) {
    }
    try {
      (void)node.getList<double>(key);
    } catch (const config::Error&) {
    }
    try {
      (void)node.getChoice(key, {"a", "b"});
    } catch (const config::Error&) {
    }
    try {
      for (const config::Node& element : node.children(key))
        readEverything(element, depth + 1);
    } catch (const config::Error&) {
    }
    try {
      readEverything(node.child(key), depth + 1);
    } catch (const config::Error&) {
    }
  }
  try {
    node.rejectUnknownKeys();
  } catch (const config::Error&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const config::Node root = config::Node::loadString(text, "fuzz.yaml");
    readEverything(root, 0);
  } catch (const config::Error&) {
  }
  return 0;
}
