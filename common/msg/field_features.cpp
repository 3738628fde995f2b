#include "common/msg/field_features.hpp"

namespace fieldline::msg {

using perception::FeatureKind;
static_assert(static_cast<int>(FeatureKind::kCentreCircle) == field_features_t::KIND_CENTER_CIRCLE);
static_assert(static_cast<int>(FeatureKind::kPenaltyCorner) ==
              field_features_t::KIND_PENALTY_CORNER);
static_assert(static_cast<int>(FeatureKind::kFieldCorner) == field_features_t::KIND_FIELD_CORNER);
static_assert(static_cast<int>(FeatureKind::kTJunction) == field_features_t::KIND_T_JUNCTION);
static_assert(static_cast<int>(FeatureKind::kStraightLine) == field_features_t::KIND_STRAIGHT_LINE);
static_assert(static_cast<int>(FeatureKind::kGoal) == field_features_t::KIND_GOAL);

void fromMessage(const field_features_t& m, perception::FieldFeatures& out) {
  out.clear();
  out.features.resize(static_cast<std::size_t>(m.num_features));
  for (std::size_t i = 0; i < out.features.size(); ++i) {
    auto& f = out.features[i];
    f.kind = static_cast<FeatureKind>(m.kind[i]);
    f.local = {m.feature_x[i], m.feature_y[i], m.feature_phi[i]};
    f.quality = m.quality[i];
  }
  out.hypotheses.resize(static_cast<std::size_t>(m.num_hypotheses));
  for (std::size_t i = 0; i < out.hypotheses.size(); ++i) {
    auto& h = out.hypotheses[i];
    h.feature = m.hypothesis_feature[i];
    h.pose = {m.pose_x[i], m.pose_y[i], m.pose_phi[i]};
    h.sigma_xy = m.sigma_xy[i];
    h.sigma_phi = m.sigma_phi[i];
  }
}

void toMessage(const perception::FieldFeatures& features, field_features_t& m) {
  const std::size_t n = features.features.size();
  m.num_features = static_cast<std::int32_t>(n);
  m.kind.resize(n);
  m.feature_x.resize(n);
  m.feature_y.resize(n);
  m.feature_phi.resize(n);
  m.quality.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& f = features.features[i];
    m.kind[i] = static_cast<std::int8_t>(f.kind);
    m.feature_x[i] = static_cast<float>(f.local.x);
    m.feature_y[i] = static_cast<float>(f.local.y);
    m.feature_phi[i] = static_cast<float>(f.local.phi);
    m.quality[i] = static_cast<float>(f.quality);
  }
  const std::size_t h = features.hypotheses.size();
  m.num_hypotheses = static_cast<std::int32_t>(h);
  m.hypothesis_feature.resize(h);
  m.pose_x.resize(h);
  m.pose_y.resize(h);
  m.pose_phi.resize(h);
  m.sigma_xy.resize(h);
  m.sigma_phi.resize(h);
  for (std::size_t i = 0; i < h; ++i) {
    const auto& p = features.hypotheses[i];
    m.hypothesis_feature[i] = p.feature;
    m.pose_x[i] = static_cast<float>(p.pose.x);
    m.pose_y[i] = static_cast<float>(p.pose.y);
    m.pose_phi[i] = static_cast<float>(p.pose.phi);
    m.sigma_xy[i] = static_cast<float>(p.sigma_xy);
    m.sigma_phi[i] = static_cast<float>(p.sigma_phi);
  }
}

}  // namespace fieldline::msg
