#include "common/robot/omni_kinematics.hpp"

#include <cmath>
#include <stdexcept>

#include <string>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

namespace fieldline::robot {

namespace {

WheelMatrix wheelMatrix(const WheelSet& wheels, double phi) {
  WheelMatrix m(static_cast<Eigen::Index>(wheels.size()), 3);
  for (std::size_t i = 0; i < wheels.size(); ++i) {
    const double a = phi + wheels[i].angle;
    m.row(static_cast<Eigen::Index>(i)) << -std::sin(a), std::cos(a), wheels[i].distance;
  }
  return m;
}

}  // namespace

bool wheelLayoutRegular(const WheelSet& wheels) {
  if (wheels.size() < kMinWheels || wheels.size() > kMaxWheels) return false;
  const WheelMatrix m = wheelMatrix(wheels, 0.0);
  if (wheels.size() == 3) {
    // A layout with two parallel wheels (or all wheels on one line) loses a degree of freedom.
    const Eigen::Matrix3d square = m;
    Eigen::FullPivLU<Eigen::Matrix3d> lu(square);
    const double cond_guard = 1e-6 * square.cwiseAbs().maxCoeff();
    return lu.isInvertible() && std::abs(lu.determinant()) >= cond_guard;
  }
  // More wheels than degrees of freedom: M must still have rank 3, well conditioned. M's
  // singular values are the square roots of the eigenvalues of the 3x3 M^T M (a fixed-size
  // solver: an SVD of the dynamic-size M costs half a minute of compile time for this check).
  const Eigen::Matrix3d normal = m.transpose() * m;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(normal, Eigen::EigenvaluesOnly);
  const Eigen::Vector3d& lambda = eigen.eigenvalues();  // ascending
  return lambda(0) >= 1e-12 * lambda(2);
}

OmniKinematics::OmniKinematics(const WheelSet& wheels) : wheels_(wheels) {
  const auto n = static_cast<Eigen::Index>(wheels.size());
  if (n < kMinWheels || n > kMaxWheels) {
    throw std::invalid_argument("omni kinematics: " + std::to_string(n) +
                                " wheels (3 or 4 supported)");
  }
  radii_.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& w = wheels[static_cast<std::size_t>(i)];
    if (!(w.radius > 0.0) || !(w.distance > 0.0)) {
      throw std::invalid_argument("omni kinematics: wheel radius and distance must be positive");
    }
    radii_[i] = w.radius;
  }
  m_ = wheelMatrix(wheels, 0.0);
  if (!wheelLayoutRegular(wheels)) {
    throw std::invalid_argument("omni kinematics: wheel layout is singular");
  }
  if (n == 3) {
    const Eigen::Matrix3d square = m_;
    m_inv_ = Eigen::FullPivLU<Eigen::Matrix3d>(square).inverse();
  } else {
    // Least squares: the twist minimising the squared differences of the wheel speeds,
    // (M^T M)^-1 M^T (M^T M is 3x3 and positive definite for a regular layout).
    const Eigen::Matrix3d normal = m_.transpose() * m_;
    m_inv_ = normal.ldlt().solve(m_.transpose());
  }
}

WheelMatrix OmniKinematics::fieldMatrix(double phi) const {
  return wheelMatrix(wheels_, phi);
}

WheelMatrixInverse OmniKinematics::fieldMatrixInverse(double phi) const {
  // W(phi) = M * diag(R(-phi), 1), so its inverse is diag(R(phi), 1) * M^+.
  Eigen::Matrix3d rot = Eigen::Matrix3d::Identity();
  rot(0, 0) = std::cos(phi);
  rot(0, 1) = -std::sin(phi);
  rot(1, 0) = std::sin(phi);
  rot(1, 1) = std::cos(phi);
  return rot * m_inv_;
}

WheelVector OmniKinematics::wheelAngularSpeeds(const Twist& twist) const {
  return wheelSpeeds(twist).cwiseQuotient(radii_);
}

Twist OmniKinematics::twistFromAngularSpeeds(const WheelVector& wheel_angular_speeds) const {
  return twist(wheel_angular_speeds.cwiseProduct(radii_));
}

geometry::Movement OmniKinematics::movementFromWheelRotations(
    const WheelVector& wheel_rotations) const {
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

namespace fieldline::robot {

Eigen::Vector3d integratedTwist(const geometry::Movement& movement) {
  // arcMovement maps (sx, sy) through [[s, -c], [c, s]] (s = sin th / th, c = (1 - cos th) / th);
  // its inverse is [[s, c], [-c, s]] / (s^2 + c^2).
  const double th = movement.dphi;
  double s = 1.0;
  double c = 0.5 * th;
  if (std::abs(th) >= 1e-9) {
    s = std::sin(th) / th;
    c = (1.0 - std::cos(th)) / th;
  }
  const double norm = s * s + c * c;
  return {(s * movement.dx + c * movement.dy) / norm, (-c * movement.dx + s * movement.dy) / norm,
          th};
}

}  // namespace fieldline::robot
