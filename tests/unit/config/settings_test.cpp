// The declaration facility (common/config/settings.hpp): one table gives the loader (ranges,
// unknown keys, cross checks, all naming file:line and key), the YAML a preset ships and the
// docs table, and tells when a shipped file or a docs page has drifted from the declarations.
#include "common/config/settings.hpp"

#include <cstdint>
#include <string>

#include <gtest/gtest.h>

namespace fieldline::config {
namespace settings_test {

enum class Mode { kFast, kExact };

struct Inner {
  double gain = 0.5;
  std::int64_t hold_us = 250'000;
};

struct Params {
  int steps = 3;
  std::size_t points = 30;
  bool enabled = true;
  Mode mode = Mode::kExact;
  Inner inner;
};

const SettingsTable<Params>& table() {
  static const auto t = [] {
    SettingsTable<Params> t;
    t.section("search", "The search.");
    t.add("search.steps", 0, 20, "1", "Steps each side | both ways", &Params::steps);
    t.add("search.points", std::size_t{1}, std::size_t{1000}, "1", "Fewer points: no search",
          &Params::points);
    t.addBool("search.enabled", "Search at all", &Params::enabled);
    t.addChoice<Mode>("mode", {{"fast", Mode::kFast}, {"exact", Mode::kExact}}, "How",
                      &Params::mode);
    t.add("inner.gain", 0.0, 1.0, "1", "The gain", &Params::inner, &Inner::gain);
    t.addSeconds("inner.hold_s", 0.0, 5.0, "Held this long", &Params::inner, &Inner::hold_us);
    t.check({"inner.gain", "search.steps"}, [](const Params& p) -> std::optional<std::string> {
      if (p.inner.gain > 0.9 && p.steps > 10) return "gain above 0.9 needs steps at most 10";
      return std::nullopt;
    });
    return t;
  }();
  return t;
}

std::string errorOf(const std::string& text) {
  try {
    table().load(Node::loadString(text, "p.yaml"));
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Settings, AbsentKeysKeepTheDefaultsGivenOnesApply) {
  const Params p = table().load(Node::loadString(
      "search:\n  steps: 5\n  enabled: false\nmode: fast\ninner:\n  hold_s: 0.5\n"));
  EXPECT_EQ(p.steps, 5);
  EXPECT_EQ(p.points, 30u);
  EXPECT_FALSE(p.enabled);
  EXPECT_EQ(p.mode, Mode::kFast);
  EXPECT_DOUBLE_EQ(p.inner.gain, 0.5);
  EXPECT_EQ(p.inner.hold_us, 500'000);
  EXPECT_EQ(table().load(Node::loadString("{}")).steps, 3);
}

TEST(Settings, ErrorsNameFileLineKeyAndRange) {
  const std::string range = errorOf("search:\n  steps: 21\n");
  EXPECT_NE(range.find("p.yaml:2"), std::string::npos) << range;
  EXPECT_NE(range.find("search.steps"), std::string::npos) << range;
  EXPECT_NE(range.find("[0, 20]"), std::string::npos) << range;
  const std::string unknown = errorOf("search:\n  steps: 2\n  stpes: 2\n");
  EXPECT_NE(unknown.find("p.yaml:3"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("stpes"), std::string::npos) << unknown;
  EXPECT_NE(errorOf("serch:\n  steps: 2\n").find("serch"), std::string::npos);
  EXPECT_NE(errorOf("mode: slow\n").find("mode"), std::string::npos);
  EXPECT_NE(errorOf("search:\n  enabled: maybe\n"), "");
  EXPECT_NE(errorOf("inner:\n  gain: .nan\n"), "");
  EXPECT_NE(errorOf("search:\n  steps:\n").find("has no value"), std::string::npos);
  // A cross check is located at the first of its keys the file gives.
  const std::string cross = errorOf("search:\n  steps: 12\ninner:\n  gain: 0.95\n");
  EXPECT_NE(cross.find("p.yaml:4: inner.gain: gain above 0.9"), std::string::npos) << cross;
}

TEST(Settings, PrintedYamlReadsBackToTheSameValues) {
  Params changed;
  changed.steps = 7;
  changed.inner.gain = 0.017;
  changed.mode = Mode::kFast;
  const std::string text = table().yaml(changed, "# header\n");
  EXPECT_NE(text.find("# The search.\nsearch:\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  # Steps each side | both ways [1, [0, 20]]\n  steps: 7\n"),
            std::string::npos)
      << text;
  const Params back = table().load(Node::loadString(text));
  EXPECT_TRUE(table().differences(back, changed).empty());
  EXPECT_EQ(table().yaml(back, "# header\n"), text);
}

TEST(Settings, AShippedValueThatDiffersFromItsDefaultIsFound) {
  // What the shipped-preset tests of each service assert: the file loads to the defaults.
  const Params shipped = table().load(Node::loadString("search:\n  steps: 3\n"));
  EXPECT_TRUE(table().differences(shipped, Params{}).empty());
  const Params drifted = table().load(Node::loadString("inner:\n  hold_s: 0.4\n"));
  const auto diff = table().differences(drifted, Params{});
  ASSERT_EQ(diff.size(), 1u);
  EXPECT_EQ(diff[0], "inner.hold_s: 0.4 vs 0.25");
}

TEST(Settings, ADeclaredSettingMissingFromTheDocsTableIsFound) {
  const std::string markdown = table().markdown(Params{});
  EXPECT_TRUE(table().missingFrom(markdown).empty()) << markdown;
  EXPECT_NE(markdown.find("| `search.steps` | 3 | 1 | [0, 20] | Steps each side \\| both ways |"),
            std::string::npos)
      << markdown;
  std::string without = markdown;
  const auto row = without.find("| `inner.gain`");
  without.erase(row, without.find('\n', row) - row + 1);
  const auto missing = table().missingFrom(without);
  ASSERT_EQ(missing.size(), 1u);
  EXPECT_EQ(missing[0], "inner.gain");
}

TEST(Settings, NumbersPrintShortAndReadBack) {
  EXPECT_EQ(formatNumber(0.017), "0.017");
  EXPECT_EQ(formatNumber(40.0), "40");
  EXPECT_EQ(formatNumber(1e-6), "1.0e-06");
  EXPECT_DOUBLE_EQ(Node::loadString("x: " + formatNumber(1e-6)).get<double>("x"), 1e-6);
  EXPECT_EQ(formatNumber(16.27), "16.27");
}

}  // namespace settings_test
}  // namespace fieldline::config
