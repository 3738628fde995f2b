#include "common/msg/line_contours.hpp"

namespace fieldline::msg {

void fromMessage(const line_contours_t& m, perception::LinePoints& out) {
  out.clear();
  out.points.resize(static_cast<std::size_t>(m.num_points));
  for (std::size_t i = 0; i < out.points.size(); ++i) {
    out.points[i] = {m.u[i], m.v[i], m.x[i], m.y[i]};
  }
  out.sequences.resize(static_cast<std::size_t>(m.num_sequences));
  for (std::size_t i = 0; i < out.sequences.size(); ++i) {
    out.sequences[i] = {m.sequence_start[i], m.sequence_end[i]};
  }
}

perception::LinePoints toLinePoints(const line_contours_t& m) {
  perception::LinePoints out;
  fromMessage(m, out);
  return out;
}

void toMessage(const perception::LinePoints& lines, line_contours_t& m) {
  const std::size_t n = lines.points.size();
  m.num_points = static_cast<std::int32_t>(n);
  m.u.resize(n);
  m.v.resize(n);
  m.x.resize(n);
  m.y.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    m.u[i] = lines.points[i].u;
    m.v[i] = lines.points[i].v;
    m.x[i] = lines.points[i].x;
    m.y[i] = lines.points[i].y;
  }
  const std::size_t s = lines.sequences.size();
  m.num_sequences = static_cast<std::int32_t>(s);
  m.sequence_start.resize(s);
  m.sequence_end.resize(s);
  for (std::size_t i = 0; i < s; ++i) {
    m.sequence_start[i] = lines.sequences[i].first;
    m.sequence_end[i] = lines.sequences[i].second;
  }
}

}  // namespace fieldline::msg
