// The sensor-model calibration's fit (tools/fidelity/sensor_calibration.h,
// docs/algorithms.md §3.7) against data drawn from the model itself.
#include "tools/fidelity/sensor_calibration.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

namespace kestrel {
namespace {

constexpr double kZMin = 0.61, kZMax = 4.0;

// Rays drawn from the forward model of docs/algorithms.md §3.1 with the given values: a third of
// them with nothing in range.
SensorCalibrator Draw(double sigma, double p_rand, double p_miss, int rays, uint32_t seed) {
  SensorCalibrator cal(kZMin, kZMax);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, sigma);
  for (int i = 0; i < rays; ++i) {
    const bool in_range = i % 3 != 0;
    const double d = in_range ? 0.8 + 3.0 * unit(rng) : std::numeric_limits<double>::infinity();
    const double spurious_z = kZMin + (kZMax - kZMin) * unit(rng);
    if (unit(rng) < p_rand) {
      cal.Add(d, d, true, spurious_z);
    } else if (!in_range || unit(rng) < p_miss) {
      cal.Add(d, d, false, 0.0);
    } else {
      cal.Add(d, d, true, d + gauss(rng));
    }
  }
  return cal;
}

TEST(SensorCalibrator, RecoversTheValuesTheDataWasDrawnWith) {
  for (const auto& [sigma, p_rand, p_miss] :
       {std::tuple{0.03, 0.08, 0.04}, std::tuple{0.012, 0.005, 0.2}, std::tuple{0.1, 0.2, 0.01}}) {
    const SensorCalibration c = Draw(sigma, p_rand, p_miss, 300000, 7).Fit();
    EXPECT_TRUE(c.converged);
    EXPECT_NEAR(c.sigma_m, sigma, 0.03 * sigma) << sigma;
    EXPECT_NEAR(c.p_rand, p_rand, 0.05 * p_rand + 0.002) << p_rand;
    EXPECT_NEAR(c.p_miss, p_miss, 0.05 * p_miss + 0.002) << p_miss;
    EXPECT_EQ(c.rays_in_range + c.rays_out_of_range, 300000);
  }
}

TEST(SensorCalibrator, SurfaceSigmaLeavesOutTheCellTerm) {
  // d_k a whole 7.5 cm cell's chord midpoint away from d, uniformly: sigma about d_k holds the
  // quantisation (alpha^2 / 12), sigma about d does not.
  SensorCalibrator cal(kZMin, kZMax);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 0.02);
  const double alpha = 0.075;
  for (int i = 0; i < 200000; ++i) {
    const double d = 1.0 + 2.0 * unit(rng);
    const double d_k = d + alpha * (unit(rng) - 0.5);
    cal.Add(d, d_k, true, d + gauss(rng));
  }
  const SensorCalibration c = cal.Fit();
  EXPECT_NEAR(c.sigma_surface_m, 0.02, 0.0006);
  EXPECT_NEAR(c.sigma_m, std::sqrt(0.02 * 0.02 + alpha * alpha / 12.0), 0.0015);
}

// A sensor whose no-return is no evidence shows out-of-range rays only when they return: left
// out, they do not count as spurious returns (p_rand stays the in-range data's).
TEST(SensorCalibrator, OutOfRangeRaysLeftOutForASensorWhoseZeroIsNoEvidence) {
  SensorCalibrator seen = Draw(0.03, 0.02, 0.05, 20000, 3);
  SensorCalibrator unseen = Draw(0.03, 0.02, 0.05, 20000, 3);
  unseen.LeaveOutOutOfRangeRays();
  for (int i = 0; i < 2000; ++i) {
    seen.Add(kZMax + 1.0, kZMax + 1.0, true, 1.0 + 0.001 * i);
    unseen.Add(kZMax + 1.0, kZMax + 1.0, true, 1.0 + 0.001 * i);
  }
  const SensorCalibration a = seen.Fit();
  const SensorCalibration b = unseen.Fit();
  EXPECT_EQ(a.rays_out_of_range, b.rays_out_of_range + 2000);
  EXPECT_EQ(b.returns_out_of_range, a.returns_out_of_range - 2000);
  EXPECT_NEAR(b.p_rand, 0.02, 0.005);
  EXPECT_GT(a.p_rand, b.p_rand + 0.05) << "counted, the 2000 returns read as spurious";
}

TEST(SensorCalibrator, RefusesBadLimitsAndAnEmptyFit) {
  EXPECT_THROW(SensorCalibrator(1.0, 0.5), std::invalid_argument);
  EXPECT_THROW(SensorCalibrator(0.5, 4.0, 0.001), std::invalid_argument);
  SensorCalibrator cal(kZMin, kZMax);
  cal.Add(2.0, 2.0, false, 0.0);
  EXPECT_THROW((void)cal.Fit(), std::runtime_error);
}

}  // namespace
}  // namespace kestrel
