#include "services/fusion/ekf.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Cholesky>
#include <Eigen/LU>

namespace fieldline::fusion {
namespace {

void symmetrize(StateMatrix& p) {
  p = 0.5 * (p + p.transpose()).eval();
}

// The gyro bias's random walk over dt.
void addBiasWalk(StateMatrix& p, double dt, const ProcessNoise& n) {
  p(kGyroBias, kGyroBias) += n.gyro_bias_walk * n.gyro_bias_walk * dt;
}

// P <- (I - K H) P (I - K H)^T + K R K^T (Joseph form) without forming the 9x9 I - K H: with
// A = P - K (H P) it is A - (A H^T) K^T + K R K^T, products of 9x3 and 3x9 only (a late measurement
// replays every update and prediction after it).
void josephUpdate(StateMatrix& p, const Eigen::Matrix<double, kStateSize, 3>& k,
                  const Eigen::Matrix<double, 3, kStateSize>& h, const Eigen::Matrix3d& r) {
  const StateMatrix a = p - k * (h * p);
  const Eigen::Matrix<double, kStateSize, 3> kr = k * r;
  p = a - (a * h.transpose()) * k.transpose() + kr * k.transpose();
}

// Velocity random walk (white acceleration) over dt for a 6-state of pose and velocity.
StateMatrix accelerationNoise(double dt, const ProcessNoise& n, bool with_position) {
  StateMatrix q = StateMatrix::Zero();
  const double qa[3] = {n.linear_acceleration * n.linear_acceleration,
                        n.linear_acceleration * n.linear_acceleration,
                        n.angular_acceleration * n.angular_acceleration};
  for (int i = 0; i < 3; ++i) {
    q(i + 3, i + 3) = qa[i] * dt;
    if (with_position) {
      q(i, i) = qa[i] * dt * dt * dt / 3.0;
      q(i, i + 3) = q(i + 3, i) = qa[i] * dt * dt / 2.0;
    }
  }
  if (with_position) {
    q(0, 0) += n.position_density * n.position_density * dt;
    q(1, 1) += n.position_density * n.position_density * dt;
    q(2, 2) += n.heading_density * n.heading_density * dt;
  }
  return q;
}

}  // namespace

ProcessNoise ProcessNoise::fromMotorModel(const robot::MotorModel& motor,
                                          const robot::OmniKinematics& kinematics) {
  // Each wheel's unseen acceleration spread over +-alpha/m, as a standard deviation of half
  // that, kept for about one motor time constant.
  const double wheel_sigma = 0.5 * motor.alpha() / motor.mass();
  const robot::WheelMatrixInverse& m_inv = kinematics.robotMatrixInverse();
  const Eigen::Matrix3d body = m_inv * (wheel_sigma * wheel_sigma) * m_inv.transpose();
  const double tau = motor.timeConstant();
  ProcessNoise n;
  n.linear_acceleration = std::sqrt(0.5 * (body(0, 0) + body(1, 1)) * tau);
  n.angular_acceleration = std::sqrt(body(2, 2) * tau);
  return n;
}

void predictConstantVelocity(EkfState& s, Utime t, const ProcessNoise& noise) {
  if (t <= s.utime) return;
  const double dt = static_cast<double>(t - s.utime) * 1e-6;
  // F = I + dt (e0 e3^T + e1 e4^T + e2 e5^T); F P F^T by rows and then columns.
  for (int i = 0; i < 3; ++i)
    s.x[i] += dt * s.x[i + 3];
  s.x[2] = geometry::normalizeAngle(s.x[2]);
  for (int i = 0; i < 3; ++i)
    s.p.row(i) += dt * s.p.row(i + 3);
  for (int i = 0; i < 3; ++i)
    s.p.col(i) += dt * s.p.col(i + 3);
  s.p += accelerationNoise(dt, noise, true);
  addBiasWalk(s.p, dt, noise);
  symmetrize(s.p);
  s.utime = t;
}

void predictOdometryPart(EkfState& s, const OdometryStep& step, Utime t,
                         const ProcessNoise& noise) {
  if (step.t_end <= step.t_start) return;
  t = std::min(t, step.t_end);
  if (s.utime < step.t_start) predictConstantVelocity(s, std::min(t, step.t_start), noise);
  if (s.utime >= t) return;
  // The step's body twist is taken as constant over the interval: the part [s.utime, t] moves
  // by that fraction of the twist (arcs compose: a fraction a and then 1 - a of a constant twist
  // is the whole arc) and adds that fraction of the step's covariance, so a state carried to a
  // time inside the interval and on to its end has moved exactly as the whole step.
  const double fraction =
      static_cast<double>(t - s.utime) / static_cast<double>(step.t_end - step.t_start);
  const double dt = static_cast<double>(t - s.utime) * 1e-6;
  Eigen::Vector3d part = fraction * step.integrated;
  // The gyro's rotation less its bias over the part of the step.
  if (step.gyro) part.z() -= s.x[kGyroBias] * dt;
  const geometry::Movement m = robot::arcMovement(part);
  const double phi = s.x[2];
  const double c = std::cos(phi), sn = std::sin(phi);

  // F = I + f02 e0 e2^T + f12 e1 e2^T (- dt e2 e_bias^T with the gyro); F P F^T by rows and
  // then columns, row and column 2 last (the others take them as they were).
  const double f02 = -sn * m.dx - c * m.dy;
  const double f12 = c * m.dx - sn * m.dy;
  Eigen::Matrix3d g;  // the step's body frame into the field frame
  g << c, -sn, 0.0, sn, c, 0.0, 0.0, 0.0, 1.0;

  s.x[0] += c * m.dx - sn * m.dy;
  s.x[1] += sn * m.dx + c * m.dy;
  s.x[2] = geometry::normalizeAngle(phi + m.dphi);
  s.p.row(0) += f02 * s.p.row(2);
  s.p.row(1) += f12 * s.p.row(2);
  if (step.gyro) s.p.row(2) -= dt * s.p.row(kGyroBias);
  s.p.col(0) += f02 * s.p.col(2);
  s.p.col(1) += f12 * s.p.col(2);
  if (step.gyro) s.p.col(2) -= dt * s.p.col(kGyroBias);
  s.p.topLeftCorner<3, 3>() += fraction * g * step.covariance * g.transpose();
  s.p += accelerationNoise(dt, noise, false);
  addBiasWalk(s.p, dt, noise);
  symmetrize(s.p);
  s.utime = t;
  s.gyro = step.gyro;
}

void predictOdometry(EkfState& s, const OdometryStep& step, const ProcessNoise& noise) {
  // Only the part of the step after the state's time moves it (a measurement may already have
  // carried the state into the interval).
  if (s.utime >= step.t_end || step.t_end <= step.t_start) return;
  predictOdometryPart(s, step, step.t_end, noise);
  updateOdometryVelocity(s, step, noise);
}

void updateOdometryVelocity(EkfState& s, const OdometryStep& step, const ProcessNoise& noise) {
  if (!step.has_velocity || s.utime != step.t_end || step.t_end <= step.t_start) return;
  // The step's mean velocity, in the field frame at the middle of the step's heading change.
  const double duration = step.duration();
  const double phi_mid = s.x[2] - 0.5 * step.integrated.z();
  const Eigen::Vector2d v_body = step.integrated.head<2>() / duration;
  Eigen::Vector3d z;
  z.head<2>() = geometry::rotate(v_body, phi_mid);
  z[2] = step.integrated.z() / duration;
  Eigen::Matrix3d r = Eigen::Matrix3d::Zero();
  r.topLeftCorner<2, 2>() = Eigen::Matrix2d::Identity() *
                            (step.covariance(0, 0) + step.covariance(1, 1)) /
                            (2.0 * duration * duration);
  r(2, 2) = step.covariance(2, 2) / (duration * duration);
  r(0, 0) += noise.odometry_velocity_sigma * noise.odometry_velocity_sigma;
  r(1, 1) += noise.odometry_velocity_sigma * noise.odometry_velocity_sigma;
  r(2, 2) += noise.odometry_omega_sigma * noise.odometry_omega_sigma;

  Eigen::Matrix<double, 3, kStateSize> h = Eigen::Matrix<double, 3, kStateSize>::Zero();
  h.block<3, 3>(0, 3).setIdentity();
  // The gyro measures the rotation rate plus its bias.
  if (step.gyro) h(2, kGyroBias) = 1.0;
  const Eigen::Vector3d y = z - h * s.x;
  const Eigen::Matrix3d sm = h * s.p * h.transpose() + r;
  const Eigen::Matrix<double, kStateSize, 3> k = s.p * h.transpose() * sm.inverse();
  s.x += k * y;
  s.x[2] = geometry::normalizeAngle(s.x[2]);
  josephUpdate(s.p, k, h, r);
  symmetrize(s.p);
}

namespace {

// (1 - exp(-x)) / x, 1 at 0.
double decayGain(double x) {
  return x < 1e-12 ? 1.0 : -std::expm1(-x) / x;
}

// (x - 2 (1 - exp(-x)) + (1 - exp(-2x)) / 2) / x^3: the position's share of an integrated
// Ornstein-Uhlenbeck velocity's noise; its series near 0 (the closed form cancels there).
double pushPositionShare(double x) {
  if (x < 1e-2) return 1.0 / 3.0 - x / 4.0 + 7.0 * x * x / 60.0;
  return (x + 2.0 * std::expm1(-x) - 0.5 * std::expm1(-2.0 * x)) / (x * x * x);
}

}  // namespace

void predictPush(EkfState& s, double dt_s, double contact_s, const PushModel& push) {
  if (push.density <= 0.0 || !(dt_s > 0.0)) return;
  contact_s = std::clamp(contact_s, 0.0, dt_s);
  if (push.unconfirmed_us > 0 && s.last_correction_utime > 0 &&
      s.utime - s.last_correction_utime > push.unconfirmed_us) {
    contact_s = 0.0;
  }
  // The decay over the interval (its rate averaged over the contact and free parts), and the
  // noise of the contact part.
  const double x = contact_s / push.contact_decay_s + (dt_s - contact_s) / push.free_decay_s;
  const double a = std::exp(-x);
  const double g = dt_s * decayGain(x);  // position gained per m/s of push
  const double q = push.density * push.density * contact_s;
  const double q_uu = q * decayGain(2.0 * x);
  const double q_pu = 0.5 * q * dt_s * decayGain(x) * decayGain(x);
  const double q_pp = q * dt_s * dt_s * pushPositionShare(x);
  for (int k = 0; k < 2; ++k) {
    const int u = kPush + k;
    s.x[k] += g * s.x[u];
    s.x[u] *= a;
    // P <- F P F^T with F = I + g e_k e_u^T + (a - 1) e_u e_u^T, by rows and then columns.
    s.p.row(k) += g * s.p.row(u);
    s.p.row(u) *= a;
    s.p.col(k) += g * s.p.col(u);
    s.p.col(u) *= a;
    s.p(u, u) += q_uu;
    s.p(k, u) += q_pu;
    s.p(u, k) += q_pu;
    s.p(k, k) += q_pp;
  }
  symmetrize(s.p);
  const double speed = std::hypot(s.x[kPush], s.x[kPush + 1]);
  if (push.max_speed > 0.0 && speed > push.max_speed) {
    s.x[kPush] *= push.max_speed / speed;
    s.x[kPush + 1] *= push.max_speed / speed;
  }
}

UpdateResult updatePose(EkfState& s, const PoseMeasurement& z, double gate2,
                        const SlipModel& slip) {
  UpdateResult result;
  Eigen::Vector3d y(z.pose.x - s.x[0], z.pose.y - s.x[1], geometry::angleDiff(z.pose.phi, s.x[2]));
  result.heading_innovation = y[2];
  Eigen::Matrix3d r = z.covariance;
  if (s.gyro && z.robust_heading && slip.gyro_heading_chi2 > 0.0) {
    // Huber weight on the heading alone: the variance that puts the disagreement on the bound.
    const double var = s.p(2, 2) + r(2, 2);
    if (y[2] * y[2] > slip.gyro_heading_chi2 * var) {
      r(2, 2) += y[2] * y[2] / slip.gyro_heading_chi2 - var;
      result.heading_weighted_down = true;
    }
  }
  Eigen::Matrix3d sm = s.p.topLeftCorner<3, 3>() + r;
  Eigen::Matrix3d sm_inv = sm.inverse();
  result.mahalanobis2 = y.dot(sm_inv * y);
  if (!std::isfinite(result.mahalanobis2)) return result;
  if (gate2 > 0.0 && result.mahalanobis2 > gate2) {
    const double max_rad = s.gyro ? slip.max_rad_gyro : slip.max_rad;
    const double max_m = std::min(slip.max_m, slip.reachBy(s, z.utime));
    const bool within = y.head<2>().norm() <= max_m && std::abs(y[2]) <= max_rad;
    if (!z.may_reveal_slip || slip.inflation <= 0.0 || !within) return result;
    // Odometry missed a movement: the pose is as uncertain as the disagreement says (the
    // position only when the heading was weighted down against the gyro's).
    Eigen::Vector3d widen = y.cwiseAbs2();
    if (result.heading_weighted_down) widen[2] = 0.0;
    s.p.topLeftCorner<3, 3>() += slip.inflation * widen.asDiagonal().toDenseMatrix();
    sm = s.p.topLeftCorner<3, 3>() + r;
    sm_inv = sm.inverse();
    result.slip = true;
  }
  Eigen::Matrix<double, 3, kStateSize> h = Eigen::Matrix<double, 3, kStateSize>::Zero();
  h.leftCols<3>().setIdentity();
  const Eigen::Matrix<double, kStateSize, 3> k = s.p * h.transpose() * sm_inv;
  const StateVector dx = k * y;
  s.x += dx;
  s.x[2] = geometry::normalizeAngle(s.x[2]);
  josephUpdate(s.p, k, h, r);
  symmetrize(s.p);
  result.accepted = true;
  result.correction_m = dx.head<2>().norm();
  result.correction_rad = std::abs(dx[2]);
  s.last_correction_utime = z.utime;
  s.last_correction_m = result.correction_m;
  s.last_correction_rad = result.correction_rad;
  return result;
}

bool isPositiveDefinite(const Eigen::Matrix3d& c) {
  if (!c.allFinite()) return false;
  const double scale = c.cwiseAbs().maxCoeff();
  if ((c - c.transpose()).cwiseAbs().maxCoeff() > 1e-9 * std::max(scale, 1e-12)) return false;
  Eigen::LLT<Eigen::Matrix3d> llt(c);
  return llt.info() == Eigen::Success && c.diagonal().minCoeff() > 0.0;
}

geometry::Pose2 symmetricTwin(const geometry::Pose2& p) {
  return {-p.x, -p.y, geometry::normalizeAngle(p.phi + std::numbers::pi)};
}

EkfState pointMirrored(const EkfState& s) {
  // Position, field-frame velocity and push change sign; heading turns by pi; turn rate and gyro
  // bias are the same seen from either side.
  StateVector sign = StateVector::Ones();
  sign[0] = sign[1] = sign[3] = sign[4] = sign[kPush] = sign[kPush + 1] = -1.0;
  EkfState m = s;
  m.x = sign.cwiseProduct(s.x);
  m.x[2] = symmetricTwin(s.pose()).phi;
  m.p = sign.asDiagonal() * s.p * sign.asDiagonal();
  return m;
}

PoseMeasurement pointMirrored(const PoseMeasurement& z) {
  PoseMeasurement m = z;
  m.pose = symmetricTwin(z.pose);
  const Eigen::Vector3d sign(-1.0, -1.0, 1.0);
  m.covariance = sign.asDiagonal() * z.covariance * sign.asDiagonal();
  return m;
}

}  // namespace fieldline::fusion
