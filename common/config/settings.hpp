// One declaration per setting: a table per parameter struct lists each tunable value once, with
// its YAML key path, the member it sets, its unit, its range and one line of why. The default is
// the struct's own initializer (read through the member), so it is written exactly once. From the
// table come the loader (range checks, unknown keys are errors naming file:line and key), the
// `--print-config` YAML (the shipped preset is that output), and the Markdown reference table.
//
//   const config::SettingsTable<BallParams>& ballSettings() {
//     static const auto table = [] {
//       config::SettingsTable<BallParams> t;
//       t.section("ball", "The ball filter.");
//       t.add("ball.max_age_s", 0.05, 60.0, "s", "invalid after this long unseen",
//             &BallParams::max_age_s);
//       return t;
//     }();
//     return table;
//   }
//
// Members are given as a chain of member pointers (&Outer::inner, &Inner::value), so a table can
// reach into nested structs; a duration stored in microseconds is declared in seconds with
// addSeconds. A nested struct with its own table is included under a key prefix with include().
#pragma once

#include <charconv>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "common/config/config.hpp"

namespace fieldline::config {

// A number as the shortest text that reads back to the same value ("0.017", "1e-06", "40").
inline std::string formatNumber(double v) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, v);
  std::string text(buffer, result.ptr);
  // YAML reads "1e-06" as a string unless it has a dot or is plainly numeric; keep it numeric.
  if (text.find_first_of(".en") == std::string::npos) return text;
  if (text.find('e') != std::string::npos && text.find('.') == std::string::npos) {
    const auto e = text.find('e');
    text.insert(e, ".0");
  }
  return text;
}

template <typename P>
struct Setting {
  // Key path from the file's root, dot-separated: "localizer.accept_cost_m".
  std::string key;
  // Unit in brackets' words: "m", "rad", "s", "m/s", "1" (dimensionless), "" for bool or choice.
  std::string unit;
  // The accepted values: "[0.001, 1]", "true | false", "own_half | none".
  std::string range;
  // One line: what it does and why this value.
  std::string why;
  // Reads the leaf `name` of `section` into `p` (range checked); the key is present.
  std::function<void(const Node& section, const std::string& name, P& p)> read;
  // The value in `p` as YAML scalar text.
  std::function<std::string(const P& p)> show;

  std::string section() const {
    const auto dot = key.rfind('.');
    return dot == std::string::npos ? std::string() : key.substr(0, dot);
  }
  std::string leaf() const {
    const auto dot = key.rfind('.');
    return dot == std::string::npos ? key : key.substr(dot + 1);
  }
};

template <typename P>
class SettingsTable {
 public:
  // A check across settings: returns an error message when `p` is inconsistent; the error is
  // located at `key` (the first of `keys` given in the file, else the first).
  struct Check {
    std::vector<std::string> keys;
    std::function<std::optional<std::string>(const P&)> test;
  };

  // A comment for a section (printed above it in the YAML and in the docs).
  void section(const std::string& path, const std::string& comment) {
    section_comments_[path] = comment;
  }

  // A number (double, float, int, std::size_t, ...) or a bool, at the end of a member chain.
  template <typename T, typename... M>
  void add(const std::string& key, T min, T max, const std::string& unit, const std::string& why,
           M... members) {
    using V = std::remove_cvref_t<decltype(follow(std::declval<P&>(), members...))>;
    static_assert(std::is_arithmetic_v<V> && !std::is_same_v<V, bool>);
    Setting<P> s{
        key, unit, "[" + formatNumber(double(min)) + ", " + formatNumber(double(max)) + "]",
        why, {},   {}};
    s.read = [=](const Node& n, const std::string& name, P& p) {
      auto& value = follow(p, members...);
      if constexpr (std::is_floating_point_v<V>) {
        value = static_cast<V>(n.get<double>(name, double(min), double(max)));
      } else {
        value = static_cast<V>(n.get<std::int64_t>(name, std::int64_t(min), std::int64_t(max)));
      }
    };
    s.show = [=](const P& p) {
      const auto value = follow(p, members...);
      if constexpr (std::is_floating_point_v<V>) return formatNumber(double(value));
      return std::to_string(value);
    };
    settings_.push_back(std::move(s));
  }

  template <typename... M>
  void addBool(const std::string& key, const std::string& why, M... members) {
    Setting<P> s{key, "", "true | false", why, {}, {}};
    s.read = [=](const Node& n, const std::string& name, P& p) {
      follow(p, members...) = n.get<bool>(name);
    };
    s.show = [=](const P& p) { return std::string(follow(p, members...) ? "true" : "false"); };
    settings_.push_back(std::move(s));
  }

  // A duration kept in microseconds (an integer member), written in seconds in the file.
  template <typename... M>
  void addSeconds(const std::string& key, double min_s, double max_s, const std::string& why,
                  M... members) {
    Setting<P> s{key, "s", "[" + formatNumber(min_s) + ", " + formatNumber(max_s) + "]",
                 why, {},  {}};
    s.read = [=](const Node& n, const std::string& name, P& p) {
      using V = std::remove_cvref_t<decltype(follow(p, members...))>;
      follow(p, members...) = static_cast<V>(std::llround(n.get<double>(name, min_s, max_s) * 1e6));
    };
    s.show = [=](const P& p) {
      return formatNumber(static_cast<double>(follow(p, members...)) / 1e6);
    };
    settings_.push_back(std::move(s));
  }

  // An enumeration written as one of the names.
  template <typename E, typename... M>
  void addChoice(const std::string& key, std::vector<std::pair<std::string, E>> choices,
                 const std::string& why, M... members) {
    std::string range;
    std::vector<std::string> names;
    for (const auto& [name, value] : choices) {
      range += (range.empty() ? "" : " | ") + name;
      names.push_back(name);
    }
    Setting<P> s{key, "", range, why, {}, {}};
    s.read = [=](const Node& n, const std::string& name, P& p) {
      const std::string chosen = n.getChoice(name, names);
      for (const auto& [choice, value] : choices) {
        if (choice == chosen) follow(p, members...) = value;
      }
    };
    s.show = [=](const P& p) {
      const E value = follow(p, members...);
      for (const auto& [choice, v] : choices) {
        if (v == value) return choice;
      }
      return std::string("?");
    };
    settings_.push_back(std::move(s));
  }

  // Every setting of `table` under `prefix`, reaching its struct through `members`.
  template <typename S, typename... M>
  void include(const std::string& prefix, const SettingsTable<S>& table, M... members) {
    for (const auto& [path, comment] : table.sectionComments()) {
      section_comments_[path.empty() ? prefix : prefix + "." + path] = comment;
    }
    for (const Setting<S>& inner : table.settings()) {
      Setting<P> s{prefix + "." + inner.key, inner.unit, inner.range, inner.why, {}, {}};
      s.read = [=, read = inner.read](const Node& n, const std::string& name, P& p) {
        read(n, name, follow(p, members...));
      };
      s.show = [=, show = inner.show](const P& p) { return show(follow(p, members...)); };
      settings_.push_back(std::move(s));
    }
    for (const auto& inner : table.checks()) {
      Check c;
      for (const auto& k : inner.keys)
        c.keys.push_back(prefix + "." + k);
      c.test = [=, test = inner.test](const P& p) { return test(follow(p, members...)); };
      checks_.push_back(std::move(c));
    }
  }

  void check(std::vector<std::string> keys,
             std::function<std::optional<std::string>(const P&)> test) {
    checks_.push_back(Check{std::move(keys), std::move(test)});
  }

  const std::vector<Setting<P>>& settings() const { return settings_; }
  const std::vector<Check>& checks() const { return checks_; }
  const std::map<std::string, std::string>& sectionComments() const { return section_comments_; }

  // The struct's defaults overridden by `root`'s keys: every key is optional, an unknown key, a
  // value of the wrong type or out of range, or an inconsistency fails with file:line and key.
  P load(const Node& root) const {
    P p{};
    loadInto(root, p);
    return p;
  }

  void loadInto(const Node& root, P& p) const {
    std::map<std::string, std::optional<Node>> sections;
    sections.emplace("", root);
    const auto sectionNode = [&](const std::string& path) -> std::optional<Node> {
      return sectionOf(root, path, sections);
    };
    for (const Setting<P>& s : settings_) {
      const auto n = sectionNode(s.section());
      if (!n) continue;
      if (n->has(s.leaf())) {
        s.read(*n, s.leaf(), p);
      } else if (n->yaml().IsMap() && n->yaml()[s.leaf()].IsDefined()) {
        n->fail(s.leaf(), "has no value (remove the key to use the default)");
      }
    }
    for (const auto& [path, node] : sections) {
      if (node) node->rejectUnknownKeys();
    }
    for (const Check& c : checks_) {
      const auto error = c.test(p);
      if (!error) continue;
      // Located at the first of the check's keys the file gives.
      for (const auto& key : c.keys) {
        const auto dot = key.rfind('.');
        const std::string leaf = dot == std::string::npos ? key : key.substr(dot + 1);
        const auto n = sectionNode(dot == std::string::npos ? "" : key.substr(0, dot));
        if (n && n->has(leaf)) n->fail(leaf, *error);
      }
      root.fail("", c.keys.front() + ": " + *error);
    }
  }

  // The settings as a YAML file with `p`'s values, each under a comment with its why, unit and
  // range (what `--print-config` prints; the shipped preset is this text for the defaults).
  std::string yaml(const P& p, const std::string& header) const {
    std::ostringstream out;
    out << header;
    std::string open;  // the section path whose keys are being written
    for (const Setting<P>& s : settings_) {
      const std::string section = s.section();
      if (section != open) {
        // Open every level of `section` that differs from the open one.
        const auto parts = split(section);
        const auto had = split(open);
        std::size_t common = 0;
        while (common < parts.size() && common < had.size() && parts[common] == had[common]) {
          ++common;
        }
        for (std::size_t i = common; i < parts.size(); ++i) {
          const std::string indent(2 * i, ' ');
          std::string path;
          for (std::size_t j = 0; j <= i; ++j)
            path += (j ? "." : "") + parts[j];
          out << "\n";
          if (const auto it = section_comments_.find(path); it != section_comments_.end()) {
            out << comment(it->second, indent);
          }
          out << indent << parts[i] << ":\n";
        }
        open = section;
      }
      const std::string indent(2 * split(section).size(), ' ');
      std::string note = s.why;
      note += " [" + (s.unit.empty() ? std::string() : s.unit + ", ") + s.range + "]";
      out << comment(note, indent) << indent << s.leaf() << ": " << s.show(p) << "\n";
    }
    return out.str();
  }

  // The reference table in Markdown: key, default, unit, range, why; one row per setting.
  std::string markdown(const P& defaults) const {
    std::ostringstream out;
    out << "| key | default | unit | range | why |\n|---|---|---|---|---|\n";
    for (const Setting<P>& s : settings_) {
      std::string why = s.why;
      for (std::size_t i = 0; (i = why.find('|', i)) != std::string::npos; i += 2) {
        why.replace(i, 1, "\\|");
      }
      std::string range = s.range;
      for (std::size_t i = 0; (i = range.find('|', i)) != std::string::npos; i += 2) {
        range.replace(i, 1, "\\|");
      }
      out << "| `" << s.key << "` | " << s.show(defaults) << " | " << s.unit << " | " << range
          << " | " << why << " |\n";
    }
    return out.str();
  }

  // Keys of this table without a row in `markdown` (a docs page holding markdown()'s table).
  std::vector<std::string> missingFrom(const std::string& markdown) const {
    std::vector<std::string> out;
    for (const Setting<P>& s : settings_) {
      if (markdown.find("| `" + s.key + "` |") == std::string::npos) out.push_back(s.key);
    }
    return out;
  }

  // Keys whose values differ between `a` and `b`, as "key: a-value vs b-value".
  std::vector<std::string> differences(const P& a, const P& b) const {
    std::vector<std::string> out;
    for (const Setting<P>& s : settings_) {
      if (s.show(a) != s.show(b)) out.push_back(s.key + ": " + s.show(a) + " vs " + s.show(b));
    }
    return out;
  }

 private:
  template <typename R, typename... M>
  static auto& follow(R& root, M... members) {
    if constexpr (sizeof...(M) == 0) {
      return root;
    } else {
      return (root.*....*members);
    }
  }

  static std::vector<std::string> split(const std::string& path) {
    std::vector<std::string> parts;
    std::string part;
    std::istringstream in(path);
    while (std::getline(in, part, '.')) {
      if (!part.empty()) parts.push_back(part);
    }
    return parts;
  }

  // Wraps `text` into comment lines of at most 100 characters.
  static std::string comment(const std::string& text, const std::string& indent) {
    std::ostringstream out;
    std::istringstream words(text);
    std::string word;
    std::string line;
    while (words >> word) {
      if (!line.empty() && indent.size() + 2 + line.size() + 1 + word.size() > 100) {
        out << indent << "# " << line << "\n";
        line.clear();
      }
      line += (line.empty() ? "" : " ") + word;
    }
    if (!line.empty()) out << indent << "# " << line << "\n";
    return out.str();
  }

  static std::optional<Node> sectionOf(const Node& root, const std::string& path,
                                       std::map<std::string, std::optional<Node>>& cache) {
    if (const auto it = cache.find(path); it != cache.end()) return it->second;
    const auto dot = path.rfind('.');
    const std::string parent = dot == std::string::npos ? "" : path.substr(0, dot);
    const std::string name = dot == std::string::npos ? path : path.substr(dot + 1);
    std::optional<Node> out;
    if (const auto p = sectionOf(root, parent, cache); p && p->has(name))
      out = p->child(name);
    else if (p)
      p->acceptEmpty(name);
    cache.emplace(path, out);
    return out;
  }

  std::vector<Setting<P>> settings_;
  std::vector<Check> checks_;
  std::map<std::string, std::string> section_comments_;
};

}  // namespace fieldline::config
