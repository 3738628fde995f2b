// Feature recognition's settings file (config/feature_recognition/NAME.yaml, `--config`): every
// RecognitionParams member under its own name, declared once in recognitionSettings().
#pragma once

#include <string>

#include "common/config/config.hpp"
#include "common/config/settings.hpp"
#include "services/feature_recognition/params.hpp"

namespace fieldline::feature_recognition {

// Every setting: loader, --print-config, docs table (docs/settings/feature_recognition.md).
const config::SettingsTable<RecognitionParams>& recognitionSettings();
// The defaults overridden by the file's keys; config::Error with file:line for a typo or a
// value out of range.
RecognitionParams loadRecognitionParams(const config::Node& root);
// Preset name (config/feature_recognition/NAME.yaml) or path; "none": the code's defaults.
RecognitionParams loadRecognitionPreset(const std::string& name_or_path);
// `p` as a settings file (`--print-config`); the shipped preset is this for the defaults.
std::string recognitionConfigYaml(const RecognitionParams& p);
// docs/settings/feature_recognition.md.
std::string recognitionSettingsMarkdown();

}  // namespace fieldline::feature_recognition
