#include "common/msg/obstacle_observations.hpp"

namespace fieldline::msg {

void fromMessage(const obstacle_observations_t& m, perception::ObstacleSightings& out) {
  out.utime = m.header.utime;
  out.obstacles.resize(static_cast<std::size_t>(m.count));
  for (std::size_t i = 0; i < out.obstacles.size(); ++i) {
    out.obstacles[i] = {m.bearing[i], m.distance[i], m.angular_width[i],
                        m.width[i],   m.x[i],        m.y[i]};
  }
}

perception::ObstacleSightings toObstacleSightings(const obstacle_observations_t& m) {
  perception::ObstacleSightings out;
  fromMessage(m, out);
  return out;
}

void toMessage(const perception::ObstacleSightings& s, obstacle_observations_t& m) {
  m.header.utime = s.utime;
  const std::size_t n = s.obstacles.size();
  m.count = static_cast<std::int32_t>(n);
  m.bearing.resize(n);
  m.distance.resize(n);
  m.angular_width.resize(n);
  m.width.resize(n);
  m.x.resize(n);
  m.y.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const perception::ObstacleSighting& o = s.obstacles[i];
    m.bearing[i] = static_cast<float>(o.bearing);
    m.distance[i] = static_cast<float>(o.distance);
    m.angular_width[i] = static_cast<float>(o.angular_width);
    m.width[i] = static_cast<float>(o.width);
    m.x[i] = static_cast<float>(o.x);
    m.y[i] = static_cast<float>(o.y);
  }
}

}  // namespace fieldline::msg
