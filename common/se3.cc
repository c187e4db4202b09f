#include "common/se3.h"

#include <cmath>

namespace kestrel {

Eigen::Matrix3d Hat(const Eigen::Vector3d& w) {
  Eigen::Matrix3d S;
  S << 0.0, -w.z(), w.y(),  //
      w.z(), 0.0, -w.x(),   //
      -w.y(), w.x(), 0.0;
  return S;
}

Eigen::Vector3d Vee(const Eigen::Matrix3d& S) {
  return Eigen::Vector3d(S(2, 1) - S(1, 2), S(0, 2) - S(2, 0), S(1, 0) - S(0, 1)) * 0.5;
}

Eigen::Quaterniond QuaternionFromRotation(const Eigen::Matrix3d& R) {
  // Nearest rotation (polar decomposition through SVD) guards against drift.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d Ro = svd.matrixU() * svd.matrixV().transpose();
  if (Ro.determinant() < 0.0) {
    Eigen::Matrix3d U = svd.matrixU();
    U.col(2) *= -1.0;
    Ro = U * svd.matrixV().transpose();
  }
  Eigen::Quaterniond q(Ro);
  q.normalize();
  if (q.w() < 0.0) q.coeffs() *= -1.0;
  return q;
}

Eigen::Matrix3d RotationFromQuaternion(const Eigen::Quaterniond& q) {
  return q.normalized().toRotationMatrix();
}

bool QuaternionFromWxyz(const double wxyz[4], Eigen::Quaterniond* q) {
  for (int i = 0; i < 4; ++i) {
    if (!std::isfinite(wxyz[i])) return false;
  }
  const Eigen::Quaterniond candidate(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
  const double norm = candidate.norm();
  if (!(norm >= 0.5 && norm <= 1.5)) return false;
  *q = candidate.normalized();
  return true;
}

Eigen::Quaterniond QuaternionFromRotationVector(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (!(angle > 0.0)) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle));
}

Eigen::Vector3d RotationVectorOf(const Eigen::Quaterniond& q) {
  const Eigen::AngleAxisd a(q.w() < 0.0 ? Eigen::Quaterniond(-q.coeffs()) : q);
  return a.angle() * a.axis();
}

Eigen::Quaterniond QuaternionFromYaw(double yaw_rad) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()));
}

double YawOf(const Eigen::Quaterniond& q) {
  const Eigen::Vector3d x_W = q * Eigen::Vector3d::UnitX();
  return std::atan2(x_W.y(), x_W.x());
}

Pose3 Interpolate(const Pose3& X_a, const Pose3& X_b, double s) {
  Pose3 X;
  X.p = X_a.p + s * (X_b.p - X_a.p);
  Eigen::Quaterniond qb = X_b.q;
  if (X_a.q.dot(qb) < 0.0) qb.coeffs() *= -1.0;  // shortest arc
  X.q = X_a.q.slerp(s, qb).normalized();
  return X;
}

double AngleBetween(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.angularDistance(b);
}

}  // namespace kestrel
