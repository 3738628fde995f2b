// Wheel kinematics of an omni drive with three or four wheels at any angles (seed 4.4, eq.
// 4.29-4.37), in the robot frame of the architecture (x forward, y left).
//
// Wheel i touches the floor at L_i * (cos a_i, sin a_i) and drives along the tangent
// (-sin a_i, cos a_i). Its contact point moves with the robot's body twist (vx, vy, omega), so
// its ground speed along the drive direction is
//     v_i = -sin(a_i) vx + cos(a_i) vy + L_i omega                 (robot frame, matrix M)
// and, with the velocity (xdot, ydot) given in the field frame at heading phi,
//     v_i = -sin(phi + a_i) xdot + cos(phi + a_i) ydot + L_i phidot (W(phi), seed eq. 4.33).
// The seed writes cos/sin because its heading is its y axis; this is the same matrix turned by
// 90 degrees. Wheel angular speeds are v_i / r_i (eq. 4.36).
#pragma once

#include <Eigen/Core>

#include "common/geometry/geometry.hpp"
#include "common/robot/robot_params.hpp"

namespace fieldline::robot {

// Velocity of the robot body in its own frame: [m/s], [m/s], [rad/s].
struct Twist {
  double vx = 0.0;
  double vy = 0.0;
  double omega = 0.0;

  Eigen::Vector3d vector() const { return {vx, vy, omega}; }
  static Twist fromVector(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
};

// The robot-frame wheel matrix M: one row per wheel (3 or 4), wheel ground speeds = M * twist.
using WheelMatrix = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::ColMajor, kMaxWheels, 3>;
// Its inverse: twist = M^+ * wheel ground speeds (3 x wheels).
using WheelMatrixInverse = Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::ColMajor, 3, kMaxWheels>;

// True when the wheels can produce every body twist: M has rank 3, well conditioned (not two of
// three wheels parallel, not all on one line).
bool wheelLayoutRegular(const WheelSet& wheels);

class OmniKinematics {
 public:
  // Three or four wheels. Throws std::invalid_argument when the wheels cannot produce every
  // twist (singular layout) or their count is not 3 or 4.
  explicit OmniKinematics(const WheelSet& wheels);

  int wheelCount() const { return static_cast<int>(wheels_.size()); }

  // Robot-frame matrix M: wheel ground speeds [m/s] = M * (vx, vy, omega).
  const WheelMatrix& robotMatrix() const { return m_; }
  // Its inverse: (vx, vy, omega) = M^+ * wheel ground speeds. Three wheels: the exact inverse
  // (seed eq. 4.35). Four wheels: the least-squares inverse (M^T M)^-1 M^T, the twist whose wheel
  // speeds are nearest to the measured ones (four wheels disagree when they slip).
  const WheelMatrixInverse& robotMatrixInverse() const { return m_inv_; }
  // Seed eq. 4.33: wheel ground speeds = W(phi) * (xdot, ydot, phidot), velocity in the field
  // frame.
  WheelMatrix fieldMatrix(double phi) const;
  // Seed eq. 4.35: W(phi)^-1 (least squares for four wheels).
  WheelMatrixInverse fieldMatrixInverse(double phi) const;

  // Ground speed of each wheel's contact point along its drive direction [m/s].
  WheelVector wheelSpeeds(const Twist& twist) const { return m_ * twist.vector(); }
  // Angular speed of each wheel [rad/s] (eq. 4.36-4.37).
  WheelVector wheelAngularSpeeds(const Twist& twist) const;
  // The body twist that produces the given wheel ground speeds (for four wheels: the one that
  // fits them best).
  Twist twist(const WheelVector& wheel_speeds) const {
    return Twist::fromVector(m_inv_ * wheel_speeds);
  }
  // The body twist from wheel angular speeds [rad/s].
  Twist twistFromAngularSpeeds(const WheelVector& wheel_angular_speeds) const;

  // The movement in the robot frame at the start of an interval during which the twist
  // direction stayed constant and the wheels turned by `wheel_rotations` [rad]: the exact
  // circular arc, not the straight chord.
  geometry::Movement movementFromWheelRotations(const WheelVector& wheel_rotations) const;

  const WheelSet& wheels() const { return wheels_; }
  // Effective wheel radii [m].
  const WheelVector& radii() const { return radii_; }

 private:
  WheelSet wheels_;
  WheelVector radii_;
  WheelMatrix m_;
  WheelMatrixInverse m_inv_;
};

// The movement (robot frame at the start) after moving with a constant body twist whose
// integral over the interval is `integrated` (dx, dy along the body axes, dphi): an arc.
geometry::Movement arcMovement(const Eigen::Vector3d& integrated);
// The inverse of arcMovement: the integrated twist of the arc that ends at `movement`.
Eigen::Vector3d integratedTwist(const geometry::Movement& movement);

}  // namespace fieldline::robot
