#include "control/mixer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace kestrel {
namespace {

constexpr double kTol = 1e-9;

VehicleConfig Vehicle(const char* layout, double min_thrust_N) {
  VehicleConfig vehicle;
  vehicle.layout = layout;
  vehicle.min_rotor_thrust_N = min_thrust_N;
  return vehicle;
}

// Requests the rotors can produce come back exactly, as long as the thrust also lies within
// [f_min(M_xy), f_max(M_xy)] (docs/algorithms.md §11.7 defines the collective range from the roll
// and pitch moments alone; yaw never widens it).
TEST(Mixer, FeasibleRequestsAreReproducedExactly) {
  for (const char* layout : {"x", "plus"}) {
    const Mixer mixer(Vehicle(layout, 0.5));
    const Eigen::Matrix4d& B = mixer.geometry().mixer;
    const Eigen::Matrix4d B_inv = B.inverse();
    std::mt19937 rng(42);
    std::uniform_real_distribution<double> thrust(0.5, 25.0);
    int exact = 0;
    for (int trial = 0; trial < 2000; ++trial) {
      const Eigen::Vector4d T(thrust(rng), thrust(rng), thrust(rng), thrust(rng));
      const Eigen::Vector4d wrench = B * T;
      const Eigen::Vector4d without_yaw =
          B_inv * Eigen::Vector4d(wrench[0], wrench[1], wrench[2], 0.0);
      if (without_yaw.minCoeff() < 0.5 || without_yaw.maxCoeff() > 25.0) continue;
      ++exact;
      const MixerOutput out = mixer.Mix(wrench[0], wrench.tail<3>());
      EXPECT_LT((out.rotor_thrust_N - T).norm(), 1e-9) << layout;
      EXPECT_FALSE(out.roll_pitch_saturated || out.thrust_saturated || out.yaw_saturated);
    }
    EXPECT_GT(exact, 1000);
  }
}

// A grid over thrust and the three moments, far beyond the limits in every direction, checks the
// priority roll/pitch > collective > yaw claim by claim, for both layouts and two thrust floors.
TEST(Mixer, SaturationPriorityHoldsOnAGrid) {
  int cases = 0;
  for (const char* layout : {"x", "plus"}) {
    for (const double min_thrust : {0.0, 1.0}) {
      const Mixer mixer(Vehicle(layout, min_thrust));
      const double lo = mixer.min_rotor_thrust_N();
      const double hi = mixer.max_rotor_thrust_N();
      const Eigen::Matrix4d& B = mixer.geometry().mixer;
      const Eigen::Matrix4d B_inv = B.inverse();
      for (double f = -60.0; f <= 160.0; f += 11.0) {
        for (double mx = -20.0; mx <= 20.0; mx += 2.5) {
          for (double my = -20.0; my <= 20.0; my += 2.5) {
            for (double mz = -4.0; mz <= 4.0; mz += 1.0) {
              ++cases;
              const Eigen::Vector3d M(mx, my, mz);
              const MixerOutput out = mixer.Mix(f, M);
              const Eigen::Vector4d& T = out.rotor_thrust_N;
              // Always finite and within the limits; the reported wrench is what T produces.
              ASSERT_TRUE(T.allFinite());
              ASSERT_GE(T.minCoeff(), lo);
              ASSERT_LE(T.maxCoeff(), hi);
              const Eigen::Vector4d wrench = B * T;
              ASSERT_NEAR(wrench[0], out.thrust_N, kTol);
              ASSERT_LT((wrench.tail<3>() - out.moment_Nm).norm(), kTol);

              // 1. Roll/pitch: exact when some collective makes them feasible on their own,
              // otherwise scaled along the same direction to the full rotor range.
              const Eigen::Vector4d d_req = B_inv.col(1) * mx + B_inv.col(2) * my;
              const bool rp_feasible = d_req.maxCoeff() - d_req.minCoeff() <= hi - lo + kTol;
              const Eigen::Vector2d m_req(mx, my);
              const Eigen::Vector2d m_got = out.moment_Nm.head<2>();
              if (rp_feasible) {
                ASSERT_LT((m_got - m_req).norm(), 1e-7)
                    << layout << " f=" << f << " M=" << M.transpose();
              } else {
                ASSERT_TRUE(out.roll_pitch_saturated);
                ASSERT_NEAR(m_req.x() * m_got.y() - m_req.y() * m_got.x(), 0.0, 1e-6);
                ASSERT_GT(m_got.dot(m_req), 0.0);
                ASSERT_LT(m_got.norm(), m_req.norm());
                const Eigen::Vector4d d_got = B_inv.col(1) * m_got.x() + B_inv.col(2) * m_got.y();
                ASSERT_NEAR(d_got.maxCoeff() - d_got.minCoeff(), hi - lo, 1e-6);
              }

              // 2. Collective = f clamped to [f_min(M_xy), f_max(M_xy)] for the granted M_xy
              // (equal thrust shares: f_min = 4 max_i(lo - d_i), f_max = 4 min_i(hi - d_i)).
              const Eigen::Vector4d d_got = B_inv.col(1) * m_got.x() + B_inv.col(2) * m_got.y();
              const double f_min = 4.0 * (Eigen::Vector4d::Constant(lo) - d_got).maxCoeff();
              const double f_max = 4.0 * (Eigen::Vector4d::Constant(hi) - d_got).minCoeff();
              ASSERT_NEAR(out.thrust_N, std::clamp(f, f_min, std::max(f_min, f_max)), 1e-6)
                  << layout << " f=" << f << " M=" << M.transpose();

              // 3. Yaw: same sign, never more than asked; when cut, a rotor sits at the limit
              // that more yaw would cross.
              const double mz_got = out.moment_Nm.z();
              ASSERT_GE(mz_got * mz, -kTol);
              ASSERT_LE(std::abs(mz_got), std::abs(mz) + kTol);
              if (std::abs(mz_got) < std::abs(mz) - 1e-7) {
                const Eigen::Vector4d yaw_direction = B_inv.col(3) * (mz > 0 ? 1.0 : -1.0);
                bool blocked = false;
                for (int i = 0; i < 4; ++i) {
                  if (yaw_direction[i] > 0 && T[i] >= hi - 1e-7) blocked = true;
                  if (yaw_direction[i] < 0 && T[i] <= lo + 1e-7) blocked = true;
                }
                ASSERT_TRUE(blocked) << layout << " f=" << f << " M=" << M.transpose();
              }
            }
          }
        }
      }
    }
  }
  EXPECT_GT(cases, 40000);
}

// Upside down the law asks for negative thrust; the mixer must still deliver the moments that
// flip the vehicle, with the least thrust that allows them.
TEST(Mixer, NegativeThrustStillGivesFlippingMoments) {
  for (const char* layout : {"x", "plus"}) {
    const Mixer mixer(Vehicle(layout, 0.0));
    for (const double yaw_Nm : {0.0, 0.3, -0.3}) {
      const Eigen::Vector3d M(6.0, -4.0, yaw_Nm);
      const MixerOutput out = mixer.Mix(-35.0, M);
      // Roll and pitch delivered in full; the least thrust that allows them (without yaw: a
      // rotor at zero).
      EXPECT_LT((out.moment_Nm.head<2>() - M.head<2>()).norm(), 1e-9) << layout;
      EXPECT_TRUE(out.thrust_saturated);
      EXPECT_GE(out.rotor_thrust_N.minCoeff(), 0.0);
      if (yaw_Nm == 0.0) {
        EXPECT_NEAR(out.rotor_thrust_N.minCoeff(), 0.0, 1e-12);
      }
      EXPECT_GT(out.thrust_N, 0.0);
      // Yaw only where it fits (never the wrong sign).
      EXPECT_GE(out.moment_Nm.z() * yaw_Nm, -1e-12);
    }
  }
}

TEST(Mixer, NonFiniteInputGivesMinimumThrust) {
  const Mixer mixer(Vehicle("x", 0.2));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const auto& [f, M] :
       {std::pair<double, Eigen::Vector3d>{nan, Eigen::Vector3d::Zero()},
        {40.0, Eigen::Vector3d(0, nan, 0)},
        {40.0, Eigen::Vector3d(0, 0, std::numeric_limits<double>::infinity())}}) {
    const MixerOutput out = mixer.Mix(f, M);
    EXPECT_TRUE(out.input_rejected);
    EXPECT_EQ(out.rotor_thrust_N, Eigen::Vector4d::Constant(0.2));
  }
}

}  // namespace
}  // namespace kestrel
