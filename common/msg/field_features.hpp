// field_features_t (FIELD_FEATURES) <-> perception::FieldFeatures.
#pragma once

#include <fieldline/field_features_t.hpp>

#include "common/perception/field_features.hpp"

namespace fieldline::msg {

// From a validated message (kinds in range, hypotheses naming existing features).
void fromMessage(const field_features_t& m, perception::FieldFeatures& out);
// Writes features and hypotheses into `m` (header untouched).
void toMessage(const perception::FieldFeatures& features, field_features_t& m);

}  // namespace fieldline::msg
