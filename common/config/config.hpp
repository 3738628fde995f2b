// YAML configuration read into typed structs, with errors that name file, line and key path.
//
// Usage, inside a loader for one struct:
//
//   FieldParams loadFieldParams(const config::Node& n) {
//     FieldParams p;
//     p.length = n.get<double>("length", 1.0, 50.0);   // required, range-checked
//     p.name = n.get<std::string>("name");              // required
//     p.noise = n.getOr<double>("noise", 0.0);          // optional with default
//     n.rejectUnknownKeys();                            // a typo is an error, not silence
//     return p;
//   }
//
// Every failure throws config::Error whose what() reads
//   "config/field/msl.yaml:12: field.lenght: unknown key (expected one of: ...)".
// main() catches it through config::runOrExit / loadOrExit and exits with code 2.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace fieldline::config {

// Where fieldline keeps caches that are rebuilt when missing (distance grids, floor rasters):
// $XDG_CACHE_HOME/fieldline, else ~/.cache/fieldline; empty when neither variable is set.
std::string defaultCacheDirectory();

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Node {
 public:
  // Parses a YAML file; throws Error naming the file (and line for syntax errors).
  static Node loadFile(const std::string& path);
  // Parses YAML text; `name` stands in for the file name in messages.
  static Node loadString(const std::string& text, const std::string& name = "<string>");

  // Required scalar of type T (bool, int, int64_t, double, float, std::string, ...).
  template <typename T>
  T get(const std::string& key) const;
  // Required scalar in [min, max].
  template <typename T>
  T get(const std::string& key, T min, T max) const;
  // Optional scalar; `fallback` when the key is absent (a present key with a wrong type fails).
  template <typename T>
  T getOr(const std::string& key, T fallback) const;
  // Optional scalar in [min, max].
  template <typename T>
  T getOr(const std::string& key, T fallback, T min, T max) const;
  // Required list of scalars, each of type T; optionally the exact length.
  template <typename T>
  std::vector<T> getList(const std::string& key, std::optional<std::size_t> length = {}) const;
  // One of the listed strings (an enumeration in YAML).
  std::string getChoice(const std::string& key, const std::vector<std::string>& choices) const;

  // Required map child.
  Node child(const std::string& key) const;
  // Optional map child.
  std::optional<Node> childIf(const std::string& key) const;
  // Required sequence of maps (or of scalars: use `as<T>()` on the elements).
  std::vector<Node> children(const std::string& key) const;
  // Keys of this map in file order (marks none as used).
  std::vector<std::string> keys() const;
  bool has(const std::string& key) const;

  // This node's own value as a scalar of type T.
  template <typename T>
  T as() const;

  // Accepts `key:` with no value (an empty list or section) by marking it read; returns true
  // when the key is present and empty.
  bool acceptEmpty(const std::string& key) const;

  // Throws for every key of this map that no get/child call asked for.
  void rejectUnknownKeys() const;

  // Throws an Error located at `key` of this map (or at this node when key is empty).
  [[noreturn]] void fail(const std::string& key, const std::string& what) const;

  const std::string& file() const { return file_; }
  // Dotted key path from the file's root, e.g. "robot.wheels[2].angle".
  const std::string& path() const { return path_; }
  // 1-based line of this node in its file.
  int line() const;
  const YAML::Node& yaml() const { return node_; }

 private:
  // Keys read so far, per YAML map, shared by every Node that refers to the same map (so reading
  // a section through two child() calls still counts every key once).
  struct UsedKeys;
  Node(YAML::Node node, std::string file, std::string path, std::shared_ptr<UsedKeys> registry);
  Node makeChild(const YAML::Node& node, std::string path) const;
  YAML::Node lookup(const std::string& key) const;
  std::string keyPath(const std::string& key) const;
  std::string location(const std::string& key) const;
  template <typename T>
  T convert(const YAML::Node& value, const std::string& key) const;

  YAML::Node node_;
  std::string file_;
  std::string path_;
  std::shared_ptr<UsedKeys> registry_;
  std::shared_ptr<std::set<std::string>> used_;
};

// Runs `body`; on config::Error (or YAML parse trouble) prints "config error: ..." to stderr
// and exits with code 2. For main() functions.
void runOrExit(const std::function<void()>& body);

// Loads `path` and hands the root to `loader`, exiting with code 2 on any error.
template <typename T>
T loadOrExit(const std::string& path, const std::function<T(const Node&)>& loader) {
  std::optional<T> out;
  runOrExit([&] { out.emplace(loader(Node::loadFile(path))); });
  return std::move(*out);
}

// Resolves a preset name or path: "msl" in category "field" -> "<root>/config/field/msl.yaml".
// A value containing '/' or ending in .yaml is taken as a path. Root from FIELDLINE_ROOT or
// the source tree this binary was built from.
std::string resolvePreset(const std::string& category, const std::string& nameOrPath);
// The repository root used for presets and test data.
std::string projectRoot();

}  // namespace fieldline::config
