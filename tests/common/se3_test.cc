// SE(3) helpers against closed forms.
#include "common/se3.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace kestrel {
namespace {

TEST(Se3, HatIsTheCrossProductAndVeeInvertsIt) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-3, 3);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d w(u(rng), u(rng), u(rng)), v(u(rng), u(rng), u(rng));
    EXPECT_NEAR((Hat(w) * v - w.cross(v)).norm(), 0.0, 1e-12);
    EXPECT_NEAR((Vee(Hat(w)) - w).norm(), 0.0, 1e-12);
    EXPECT_NEAR((Hat(w) + Hat(w).transpose()).norm(), 0.0, 0.0);
  }
}

TEST(Se3, QuaternionRotationRoundTrip) {
  std::mt19937_64 rng(8);
  std::normal_distribution<double> n;
  for (int i = 0; i < 100; ++i) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized();
    const Eigen::Matrix3d R = RotationFromQuaternion(q);
    EXPECT_NEAR((R * R.transpose() - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-12);
    EXPECT_NEAR(AngleBetween(QuaternionFromRotation(R), q), 0.0, 1e-7);
    EXPECT_GE(QuaternionFromRotation(R).w(), 0.0);
  }
}

TEST(Se3, RotationVectorExpAndLogInvertEachOther) {
  // Exp: a rotation by |w| about w / |w| (the matrix exponential of Hat(w)); Log inverts it for
  // angles below pi, whichever sign the quaternion has; w = 0 is the identity exactly.
  EXPECT_EQ(QuaternionFromRotationVector(Eigen::Vector3d::Zero()).coeffs(),
            Eigen::Quaterniond::Identity().coeffs());
  EXPECT_EQ(RotationVectorOf(Eigen::Quaterniond::Identity()), Eigen::Vector3d::Zero());
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d w(u(rng), u(rng), u(rng));
    const Eigen::Quaterniond q = QuaternionFromRotationVector(w);
    Eigen::Matrix3d exp_hat = Eigen::Matrix3d::Identity(), term = Eigen::Matrix3d::Identity();
    for (int k = 1; k < 40; ++k) {
      term = term * Hat(w) / k;
      exp_hat += term;
    }
    EXPECT_NEAR((RotationFromQuaternion(q) - exp_hat).norm(), 0.0, 1e-12);
    EXPECT_NEAR((RotationVectorOf(q) - w).norm(), 0.0, 1e-12);
    EXPECT_NEAR((RotationVectorOf(Eigen::Quaterniond(-q.coeffs())) - w).norm(), 0.0, 1e-12);
  }
}

TEST(Se3, QuaternionFromWxyzRejectsNanAndNonUnit) {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  const double nan_q[4] = {std::nan(""), 0, 0, 0};
  const double zero_q[4] = {0, 0, 0, 0};
  const double ok_q[4] = {0, 0, 0, 1.01};
  EXPECT_FALSE(QuaternionFromWxyz(nan_q, &q));
  EXPECT_FALSE(QuaternionFromWxyz(zero_q, &q));
  EXPECT_TRUE(QuaternionFromWxyz(ok_q, &q));
  EXPECT_NEAR(q.z(), 1.0, 1e-15);
}

TEST(Se3, YawOfAndFromYawAgree) {
  for (double yaw = -3.1; yaw < 3.14; yaw += 0.37) {
    EXPECT_NEAR(YawOf(QuaternionFromYaw(yaw)), yaw, 1e-12);
  }
}

TEST(Se3, InterpolationIsLinearInPositionAndSlerpInRotation) {
  Pose3 a, b;
  a.p = Eigen::Vector3d(0, 0, 1);
  b.p = Eigen::Vector3d(2, -4, 1);
  a.q = QuaternionFromYaw(0.2);
  b.q = QuaternionFromYaw(1.0);
  const Pose3 m = Interpolate(a, b, 0.25);
  EXPECT_NEAR((m.p - Eigen::Vector3d(0.5, -1, 1)).norm(), 0.0, 1e-15);
  EXPECT_NEAR(YawOf(m.q), 0.4, 1e-12);
  // Shortest arc: -q is the same rotation.
  Pose3 c = b;
  c.q.coeffs() *= -1.0;
  EXPECT_NEAR(YawOf(Interpolate(a, c, 0.5).q), 0.6, 1e-12);
}

TEST(Se3, CompositionAndInverse) {
  Pose3 X_AB, X_BC;
  X_AB.p = Eigen::Vector3d(1, 2, 3);
  X_AB.q = Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 0.5).normalized()));
  X_BC.p = Eigen::Vector3d(-0.3, 0.1, 2);
  X_BC.q = QuaternionFromYaw(-1.1);
  const Eigen::Vector3d p_C(0.4, -0.5, 0.6);
  EXPECT_NEAR(((X_AB * X_BC) * p_C - X_AB * (X_BC * p_C)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((X_AB.inverse() * (X_AB * p_C) - p_C).norm(), 0.0, 1e-12);
}

}  // namespace
}  // namespace kestrel
