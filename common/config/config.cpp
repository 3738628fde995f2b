#include "common/config/config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <type_traits>

#include "common/config/closest.hpp"
#include "common/config/paths.hpp"

namespace fieldline::config {
namespace {

template <typename T>
std::string typeName() {
  if constexpr (std::is_same_v<T, bool>) return "a boolean";
  if constexpr (std::is_integral_v<T>) return "an integer";
  if constexpr (std::is_floating_point_v<T>) return "a number";
  if constexpr (std::is_same_v<T, std::string>) return "a string";
  return "a value";
}

template <typename T>
std::string show(const T& v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// "file:line: key.path" of `key` in `n` (the location prefix of n.fail's messages).
std::string locationOf(const Node& n, const std::string& key) {
  try {
    n.fail(key, "");
  } catch (const Error& e) {
    const std::string text = e.what();
    return text.substr(0, text.size() - 2);
  }
  return key;
}

// A required `key` is absent. When the map holds a key that nothing has read and that is a
// likely misspelling of `key` ("executabel"), that one is named as the unknown key it is, with
// the missing one.
[[noreturn]] void missingKey(const Node& n, const std::set<std::string>& used,
                             const std::string& key, const std::string& what) {
  std::vector<std::string> unread;
  if (n.yaml().IsMap()) {
    for (auto it = n.yaml().begin(); it != n.yaml().end(); ++it) {
      const std::string k = it->first.Scalar();
      if (!used.count(k)) unread.push_back(k);
    }
  }
  const std::string misspelt = closestMatch(key, unread);
  if (!misspelt.empty()) {
    throw Error(locationOf(n, misspelt) + ": unknown key (did you mean " + key + "?); " +
                locationOf(n, key) + ": " + what);
  }
  n.fail(key, what);
}

}  // namespace

struct Node::UsedKeys {
  std::vector<std::pair<YAML::Node, std::shared_ptr<std::set<std::string>>>> maps;
  std::shared_ptr<std::set<std::string>> of(const YAML::Node& node) {
    for (auto& [n, used] : maps) {
      if (n.is(node)) return used;
    }
    maps.emplace_back(node, std::make_shared<std::set<std::string>>());
    return maps.back().second;
  }
};

Node::Node(YAML::Node node, std::string file, std::string path, std::shared_ptr<UsedKeys> registry)
    : node_(std::move(node)),
      file_(std::move(file)),
      path_(std::move(path)),
      registry_(registry ? std::move(registry) : std::make_shared<UsedKeys>()),
      // Only maps have keys to track; scalars and lists get a private (unused) set.
      used_(node_.IsMap() ? registry_->of(node_) : std::make_shared<std::set<std::string>>()) {}

Node Node::makeChild(const YAML::Node& node, std::string path) const {
  return Node(node, file_, std::move(path), registry_);
}

Node Node::loadFile(const std::string& path) {
  if (!std::filesystem::exists(path)) throw Error(path + ": file not found");
  try {
    Node root(YAML::LoadFile(path), path, "", nullptr);
    if (!root.node_.IsDefined() || root.node_.IsNull()) throw Error(path + ": file is empty");
    return root;
  } catch (const Error&) {
    throw;
  } catch (const YAML::ParserException& e) {
    throw Error(path + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  } catch (const YAML::Exception& e) {
    throw Error(path + ": cannot read: " + e.what());
  }
}

Node Node::loadString(const std::string& text, const std::string& name) {
  try {
    return Node(YAML::Load(text), name, "", nullptr);
  } catch (const YAML::ParserException& e) {
    throw Error(name + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  }
}

int Node::line() const {
  const auto mark = node_.Mark();
  return mark.is_null() ? 0 : mark.line + 1;
}

std::string Node::keyPath(const std::string& key) const {
  if (key.empty()) return path_.empty() ? "<root>" : path_;
  if (path_.empty()) return key;
  return path_ + "." + key;
}

std::string Node::location(const std::string& key) const {
  int ln = line();
  if (!key.empty() && node_.IsMap()) {
    // Point at the key itself when it exists.
    for (auto it = node_.begin(); it != node_.end(); ++it) {
      if (it->first.Scalar() == key && !it->first.Mark().is_null()) ln = it->first.Mark().line + 1;
    }
  }
  return file_ + ":" + std::to_string(ln) + ": " + keyPath(key);
}

void Node::fail(const std::string& key, const std::string& what) const {
  throw Error(location(key) + ": " + what);
}

YAML::Node Node::lookup(const std::string& key) const {
  if (!node_.IsMap()) fail("", "expected a map with key '" + key + "'");
  used_->insert(key);
  return node_[key];
}

bool Node::has(const std::string& key) const {
  return node_.IsMap() && node_[key].IsDefined() && !node_[key].IsNull();
}

template <typename T>
T Node::convert(const YAML::Node& value, const std::string& key) const {
  if (!value.IsScalar()) fail(key, "expected " + typeName<T>());
  T out{};
  try {
    out = value.as<T>();
  } catch (const YAML::Exception&) {
    fail(key, "expected " + typeName<T>() + ", got '" + value.Scalar() + "'");
  }
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(out)) fail(key, "must be a finite number, got '" + value.Scalar() + "'");
  }
  return out;
}

template <typename T>
T Node::get(const std::string& key) const {
  const YAML::Node v = lookup(key);
  if (!v.IsDefined() || v.IsNull()) missingKey(*this, *used_, key, "missing required key");
  return convert<T>(v, key);
}

template <typename T>
T Node::get(const std::string& key, T min, T max) const {
  const T v = get<T>(key);
  if (!(v >= min && v <= max)) {
    fail(key, "value " + show(v) + " out of range [" + show(min) + ", " + show(max) + "]");
  }
  return v;
}

template <typename T>
T Node::getOr(const std::string& key, T fallback) const {
  if (!node_.IsMap() && node_.IsDefined() && !node_.IsNull()) fail("", "expected a map");
  used_->insert(key);
  if (!node_.IsMap() || !node_[key].IsDefined()) return fallback;
  if (node_[key].IsNull()) fail(key, "has no value (remove the key to use the default)");
  return convert<T>(node_[key], key);
}

template <typename T>
T Node::getOr(const std::string& key, T fallback, T min, T max) const {
  const T v = getOr<T>(key, fallback);
  if (!(v >= min && v <= max)) {
    fail(key, "value " + show(v) + " out of range [" + show(min) + ", " + show(max) + "]");
  }
  return v;
}

template <typename T>
std::vector<T> Node::getList(const std::string& key, std::optional<std::size_t> length) const {
  const YAML::Node v = lookup(key);
  if (!v.IsDefined() || v.IsNull()) missingKey(*this, *used_, key, "missing required key");
  if (!v.IsSequence()) fail(key, "expected a list");
  if (length && v.size() != *length) {
    fail(key, "expected " + std::to_string(*length) + " elements, got " + std::to_string(v.size()));
  }
  std::vector<T> out;
  out.reserve(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    out.push_back(makeChild(v[i], keyPath(key) + "[" + std::to_string(i) + "]").as<T>());
  }
  return out;
}

template <typename T>
T Node::as() const {
  return convert<T>(node_, "");
}

std::string Node::getChoice(const std::string& key, const std::vector<std::string>& choices) const {
  const auto v = get<std::string>(key);
  for (const auto& c : choices) {
    if (c == v) return v;
  }
  std::string list;
  for (const auto& c : choices)
    list += (list.empty() ? "" : ", ") + c;
  fail(key, "'" + v + "' is not one of: " + list);
}

Node Node::child(const std::string& key) const {
  const YAML::Node v = lookup(key);
  if (!v.IsDefined() || v.IsNull()) missingKey(*this, *used_, key, "missing required section");
  if (!v.IsMap()) fail(key, "expected a map");
  return makeChild(v, keyPath(key));
}

std::optional<Node> Node::childIf(const std::string& key) const {
  used_->insert(key);
  if (!node_.IsMap() || !node_[key].IsDefined()) return std::nullopt;
  if (node_[key].IsNull()) fail(key, "has no value (remove the key to use the defaults)");
  return child(key);
}

std::vector<Node> Node::children(const std::string& key) const {
  const YAML::Node v = lookup(key);
  if (!v.IsDefined() || v.IsNull()) missingKey(*this, *used_, key, "missing required list");
  if (!v.IsSequence()) fail(key, "expected a list");
  std::vector<Node> out;
  for (std::size_t i = 0; i < v.size(); ++i) {
    out.push_back(makeChild(v[i], keyPath(key) + "[" + std::to_string(i) + "]"));
  }
  return out;
}

bool Node::acceptEmpty(const std::string& key) const {
  if (!node_.IsMap() || !node_[key].IsDefined() || !node_[key].IsNull()) return false;
  used_->insert(key);
  return true;
}

std::vector<std::string> Node::keys() const {
  std::vector<std::string> out;
  if (!node_.IsMap()) return out;
  for (auto it = node_.begin(); it != node_.end(); ++it)
    out.push_back(it->first.Scalar());
  return out;
}

void Node::rejectUnknownKeys() const {
  if (!node_.IsMap()) return;
  std::set<std::string> seen;
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    const std::string k = it->first.Scalar();
    if (!seen.insert(k).second) {
      // yaml-cpp keeps the first of two equal keys; a silent second value is a trap.
      throw Error(file_ + ":" + std::to_string(it->first.Mark().line + 1) + ": " + keyPath(k) +
                  ": duplicate key");
    }
    if (used_->count(k)) continue;
    std::string known;
    for (const auto& u : *used_)
      known += (known.empty() ? "" : ", ") + u;
    const std::string meant =
        closestMatch(k, std::vector<std::string>(used_->begin(), used_->end()));
    fail(k, "unknown key (" + (meant.empty() ? std::string() : "did you mean " + meant + "? ") +
                "expected one of: " + known + ")");
  }
}

std::size_t editDistance(const std::string& a, const std::string& b) {
  // d[i][j]: distance between the first i characters of a and the first j of b.
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i)
    d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j)
    d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[a.size()][b.size()];
}

std::string closestMatch(const std::string& word, const std::vector<std::string>& candidates) {
  const std::size_t limit = word.size() <= 4 ? 1 : 2;
  std::string best;
  std::size_t best_distance = limit + 1;
  for (const std::string& c : candidates) {
    const std::size_t distance = editDistance(word, c);
    if (c != word && distance < best_distance) {
      best = c;
      best_distance = distance;
    }
  }
  return best;
}

#define FIELDLINE_CONFIG_INSTANTIATE(T)                                                           \
  template T Node::get<T>(const std::string&) const;                                              \
  template T Node::getOr<T>(const std::string&, T) const;                                         \
  template std::vector<T> Node::getList<T>(const std::string&, std::optional<std::size_t>) const; \
  template T Node::as<T>() const;
#define FIELDLINE_CONFIG_INSTANTIATE_RANGE(T)              \
  template T Node::get<T>(const std::string&, T, T) const; \
  template T Node::getOr<T>(const std::string&, T, T, T) const;

FIELDLINE_CONFIG_INSTANTIATE(bool)
FIELDLINE_CONFIG_INSTANTIATE(int)
FIELDLINE_CONFIG_INSTANTIATE(std::int64_t)
FIELDLINE_CONFIG_INSTANTIATE(std::uint32_t)
FIELDLINE_CONFIG_INSTANTIATE(double)
FIELDLINE_CONFIG_INSTANTIATE(float)
FIELDLINE_CONFIG_INSTANTIATE(std::string)
FIELDLINE_CONFIG_INSTANTIATE_RANGE(int)
FIELDLINE_CONFIG_INSTANTIATE_RANGE(std::int64_t)
FIELDLINE_CONFIG_INSTANTIATE_RANGE(std::uint32_t)
FIELDLINE_CONFIG_INSTANTIATE_RANGE(double)
FIELDLINE_CONFIG_INSTANTIATE_RANGE(float)

void runOrExit(const std::function<void()>& body) {
  try {
    body();
  } catch (const Error& e) {
    std::cerr << "config error: " << e.what() << "\n";
    std::exit(2);
  } catch (const YAML::Exception& e) {
    std::cerr << "config error: " << e.what() << "\n";
    std::exit(2);
  }
}

std::string executableDirectory() {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : self.parent_path().string();
}

std::string dataDirectory() {
  // No compiled-in path: an installed tree works wherever its prefix is, and a build tree has
  // the same shape (build/share/fieldline/* are symlinks into the source tree, made by CMake).
  static const std::string dir = [] {
    const std::string exe_dir = executableDirectory();
    if (exe_dir.empty()) return std::string("share/fieldline");
    return (std::filesystem::path(exe_dir) / ".." / kDataSubdirectory).lexically_normal().string();
  }();
  return dir;
}

std::string projectRoot() {
  if (const char* env = std::getenv("FIELDLINE_ROOT"); env && *env) return env;
  return dataDirectory();
}

std::string resolvePreset(const std::string& category, const std::string& nameOrPath) {
  const bool isPath = nameOrPath.find('/') != std::string::npos ||
                      (nameOrPath.size() > 5 && nameOrPath.ends_with(".yaml"));
  if (isPath) return nameOrPath;
  return projectRoot() + "/config/" + category + "/" + nameOrPath + ".yaml";
}

std::string resolveAgainst(const std::string& naming_file, const std::string& category,
                           const std::string& value) {
  const bool isPath = category.empty() || value.find('/') != std::string::npos ||
                      (value.size() > 5 && value.ends_with(".yaml"));
  if (!isPath) return value;  // a preset name: resolvePreset finds it where it is loaded
  const std::filesystem::path path(value);
  if (path.is_absolute() || naming_file.empty()) return value;
  return (std::filesystem::path(naming_file).parent_path() / path).lexically_normal().string();
}

std::string defaultCacheDirectory() {
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) {
    return std::string(xdg) + "/fieldline";
  }
  if (const char* home = std::getenv("HOME"); home && *home) {
    return std::string(home) + "/.cache/fieldline";
  }
  return {};
}

}  // namespace fieldline::config
