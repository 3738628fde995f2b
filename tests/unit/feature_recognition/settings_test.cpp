// Feature recognition's settings: the shipped preset is the declared defaults, every setting is
// in the docs table, and a file changes what it names and refuses typos with file:line.
#include "services/feature_recognition/settings.hpp"

#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace fieldline::feature_recognition {
namespace settings_test {

std::string readFile(const std::string& relative) {
  std::ifstream in(config::projectRoot() + "/" + relative);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(RecognitionSettings, TheShippedPresetEqualsTheDeclaredDefaults) {
  const auto differences =
      recognitionSettings().differences(loadRecognitionPreset("default"), RecognitionParams{});
  std::string listed;
  for (const auto& d : differences)
    listed += d + "\n";
  EXPECT_TRUE(differences.empty()) << listed;
  // Regenerate with `fieldline-feature-recognition --print-config --config none >
  // config/feature_recognition/default.yaml`.
  EXPECT_EQ(readFile("config/feature_recognition/default.yaml"),
            recognitionConfigYaml(RecognitionParams{}));
}

TEST(RecognitionSettings, EveryDeclaredSettingIsInTheDocsTable) {
  const std::string docs = readFile("docs/settings/feature_recognition.md");
  EXPECT_TRUE(recognitionSettings().missingFrom(docs).empty());
  // Regenerate with `fieldline-feature-recognition --print-settings-table > ...`.
  EXPECT_EQ(docs, recognitionSettingsMarkdown());
  // Every member of RecognitionParams is declared.
  EXPECT_EQ(recognitionSettings().settings().size(), 79u);
}

TEST(RecognitionSettings, AFileSetsWhatItNamesAndRefusesTypos) {
  const RecognitionParams p = loadRecognitionParams(config::Node::loadString(
      "circle_min_points: 25\nline_end_corners: false\nunseen_max_stretch: -1\n"));
  EXPECT_EQ(p.circle_min_points, 25);
  EXPECT_FALSE(p.line_end_corners);
  EXPECT_DOUBLE_EQ(p.unseen_max_stretch, -1.0);
  EXPECT_DOUBLE_EQ(p.model_check_tolerance, RecognitionParams{}.model_check_tolerance);
  const auto errorOf = [](const std::string& text) -> std::string {
    try {
      loadRecognitionParams(config::Node::loadString(text, "fr.yaml"));
    } catch (const config::Error& e) {
      return e.what();
    }
    return "";
  };
  const std::string typo = errorOf("max_points: 100\ncircle_min_pionts: 3\n");
  EXPECT_NE(typo.find("fr.yaml:2"), std::string::npos) << typo;
  EXPECT_NE(typo.find("circle_min_pionts"), std::string::npos) << typo;
  const std::string range = errorOf("model_check_min_share: 1.5\n");
  EXPECT_NE(range.find("fr.yaml:1: model_check_min_share"), std::string::npos) << range;
  EXPECT_NE(range.find("[0, 1]"), std::string::npos) << range;
}

}  // namespace settings_test
}  // namespace fieldline::feature_recognition
