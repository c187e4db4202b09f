#pragma once
/// @file
/// Geometry on SO(3)/SE(3) with Eigen. Frames follow Drake's monogram notation: X_AB is the pose
/// of frame B in frame A, R_AB its rotation, p_AB the position of B's origin in A. World W is
/// x east, y north, z up (docs/design.md §4). Quaternions are unit, Hamilton,
/// stored as (w, x, y, z) in messages.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace kestrel {

/// A rigid transform X_AB: rotation R_AB (unit quaternion) and translation p_AB (m).
struct Pose3 {
  Eigen::Vector3d p{Eigen::Vector3d::Zero()};            ///< translation p_AB, m
  Eigen::Quaterniond q{Eigen::Quaterniond::Identity()};  ///< rotation R_AB, unit

  /// Maps a point expressed in B to A: p_A = R_AB p_B + p_AB.
  [[nodiscard]] Eigen::Vector3d operator*(const Eigen::Vector3d& p_B) const { return q * p_B + p; }
  /// Composition X_AC = X_AB * X_BC.
  [[nodiscard]] Pose3 operator*(const Pose3& X_BC) const {
    Pose3 X_AC;
    X_AC.q = (q * X_BC.q).normalized();
    X_AC.p = q * X_BC.p + p;
    return X_AC;
  }
  /// Inverse X_BA.
  [[nodiscard]] Pose3 inverse() const {
    Pose3 X_BA;
    X_BA.q = q.conjugate();
    X_BA.p = -(X_BA.q * p);
    return X_BA;
  }
  [[nodiscard]] Eigen::Matrix3d rotation() const { return q.toRotationMatrix(); }
};

/// hat(w): the skew-symmetric matrix with hat(w) v = w x v.
[[nodiscard]] Eigen::Matrix3d Hat(const Eigen::Vector3d& w);

/// vee(S): inverse of Hat for a skew-symmetric S (the antisymmetric part is used: vee of
/// (S - S^T)/2, so a nearly skew matrix gives the nearest answer).
[[nodiscard]] Eigen::Vector3d Vee(const Eigen::Matrix3d& S);

/// Unit quaternion from a rotation matrix (re-orthonormalised; w >= 0 by convention).
[[nodiscard]] Eigen::Quaterniond QuaternionFromRotation(const Eigen::Matrix3d& R);

/// Rotation matrix from a quaternion (normalised first).
[[nodiscard]] Eigen::Matrix3d RotationFromQuaternion(const Eigen::Quaterniond& q);

/// Quaternion from (w, x, y, z) as carried in messages; returns false (and leaves q untouched)
/// unless all four are finite and the norm is within [0.5, 1.5] (then normalises).
[[nodiscard]] bool QuaternionFromWxyz(const double wxyz[4], Eigen::Quaterniond* q);

/// Exp: the unit quaternion of the rotation vector w (axis times angle, rad); the identity exactly
/// for w = 0.
[[nodiscard]] Eigen::Quaterniond QuaternionFromRotationVector(const Eigen::Vector3d& w);

/// Log: the rotation vector (axis times angle, rad, angle in [0, pi]) of a unit quaternion.
[[nodiscard]] Eigen::Vector3d RotationVectorOf(const Eigen::Quaterniond& q);

/// Rotation about world z by yaw (rad).
[[nodiscard]] Eigen::Quaterniond QuaternionFromYaw(double yaw_rad);

/// Yaw (rad, in (-pi, pi]) of the body x axis projected on the world x-y plane.
[[nodiscard]] double YawOf(const Eigen::Quaterniond& q);

/// Pose interpolation at fraction s in [0, 1]: linear in position, slerp in orientation
/// (shortest arc). s outside [0, 1] extrapolates linearly/along the same arc.
[[nodiscard]] Pose3 Interpolate(const Pose3& X_a, const Pose3& X_b, double s);

/// Geodesic angle (rad, in [0, pi]) between two rotations.
[[nodiscard]] double AngleBetween(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b);

}  // namespace kestrel
