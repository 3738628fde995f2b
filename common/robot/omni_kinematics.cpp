#include "common/robot/omni_kinematics.hpp"

#include <cmath>
#include <stdexcept>

#include <Eigen/LU>

namespace fieldline::robot {

OmniKinematics::OmniKinematics(const WheelSet& wheels) : wheels_(wheels) {
  for (int i = 0; i < kWheelCount; ++i) {
    const auto& w = wheels[i];
    if (!(w.radius > 0.0) || !(w.distance > 0.0)) {
      throw std::invalid_argument("omni kinematics: wheel radius and distance must be positive");
    }
    m_.row(i) << -std::sin(w.angle), std::cos(w.angle), w.distance;
    radii_[i] = w.radius;
  }
  Eigen::FullPivLU<Eigen::Matrix3d> lu(m_);
  // A layout with two parallel wheels (or all wheels on one line) loses a degree of freedom.
  const double cond_guard = 1e-6 * m_.cwiseAbs().maxCoeff();
  if (!lu.isInvertible() || std::abs(lu.determinant()) < cond_guard) {
    throw std::invalid_argument("omni kinematics: wheel layout is singular");
  }
  m_inv_ = lu.inverse();
}

Eigen::Matrix3d OmniKinematics::fieldMatrix(double phi) const {
  Eigen::Matrix3d w;
  for (int i = 0; i < kWheelCount; ++i) {
    const double a = phi + wheels_[i].angle;
    w.row(i) << -std::sin(a), std::cos(a), wheels_[i].distance;
  }
  return w;
}

Eigen::Matrix3d OmniKinematics::fieldMatrixInverse(double phi) const {
  // W(phi) = M * diag(R(-phi), 1), so its inverse is diag(R(phi), 1) * M^-1.
  Eigen::Matrix3d rot = Eigen::Matrix3d::Identity();
  rot(0, 0) = std::cos(phi);
  rot(0, 1) = -std::sin(phi);
  rot(1, 0) = std::sin(phi);
  rot(1, 1) = std::cos(phi);
  return rot * m_inv_;
}

Eigen::Vector3d OmniKinematics::wheelAngularSpeeds(const Twist& twist) const {
  return wheelSpeeds(twist).cwiseQuotient(radii_);
}

Twist OmniKinematics::twistFromAngularSpeeds(const Eigen::Vector3d& wheel_angular_speeds) const {
  return twist(wheel_angular_speeds.cwiseProduct(radii_));
}

geometry::Movement OmniKinematics::movementFromWheelRotations(
    const Eigen::Vector3d& wheel_rotations) const {
  return arcMovement(m_inv_ * wheel_rotations.cwiseProduct(radii_));
}

geometry::Movement arcMovement(const Eigen::Vector3d& integrated) {
  const double sx = integrated.x();
  const double sy = integrated.y();
  const double th = integrated.z();
  geometry::Movement m;
  m.dphi = th;
  if (std::abs(th) < 1e-9) {
    // Second-order series of the arc; exact enough below a nano-radian.
    m.dx = sx - 0.5 * th * sy;
    m.dy = sy + 0.5 * th * sx;
    return m;
  }
  const double s = std::sin(th) / th;
  const double c = (1.0 - std::cos(th)) / th;
  m.dx = s * sx - c * sy;
  m.dy = c * sx + s * sy;
  return m;
}

}  // namespace fieldline::robot
