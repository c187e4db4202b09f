#pragma once
/// @file
/// The rigid-body state the controller flies on. Frame convention of control/: world W is x east,
/// y north, z up, gravity along -z_W; body B is x forward, y left, z up, thrust along +z_B
/// (docs/design.md §4).

#include <Eigen/Core>
#include <Eigen/LU>
#include <cmath>

namespace kestrel {

/// Position, velocity, attitude and body angular velocity of the vehicle.
struct VehicleState {
  Eigen::Vector3d position_m{Eigen::Vector3d::Zero()};              ///< x: p_WB in W, m
  Eigen::Vector3d velocity_mps{Eigen::Vector3d::Zero()};            ///< v: dx/dt in W, m/s
  Eigen::Matrix3d R_WB{Eigen::Matrix3d::Identity()};                ///< R: body attitude in W
  Eigen::Vector3d angular_velocity_radps{Eigen::Vector3d::Zero()};  ///< W (Omega): in B, rad/s

  /// True when every entry is finite and R_WB is a rotation to within `tolerance`
  /// (|R^T R - I|_max and |det R - 1|).
  [[nodiscard]] bool IsValid(double tolerance = 1e-6) const {
    if (!position_m.allFinite() || !velocity_mps.allFinite() || !R_WB.allFinite() ||
        !angular_velocity_radps.allFinite()) {
      return false;
    }
    const double orthogonality =
        (R_WB.transpose() * R_WB - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    return orthogonality <= tolerance && std::abs(R_WB.determinant() - 1.0) <= tolerance;
  }
};

}  // namespace kestrel
