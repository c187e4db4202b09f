#include "mapping/sensor_model.h"

#include <limits>

#include "common/check.h"
#include "mapping/kernels/kernels.h"
#include "mapping/lanes.h"

namespace kestrel {

SensorModelConfig SensorModelConfig::Xtion() {
  SensorModelConfig c;
  c.sigma_m = 0.1;
  c.z_min_m = 0.61;
  c.no_return_informs = false;
  return c;
}

SensorModelConfig SensorModelConfig::Hokuyo() {
  SensorModelConfig c;
  c.sigma_m = 0.05;
  return c;
}

SensorModelConfig SensorModelConfig::PaperXtion() {
  SensorModelConfig c;
  c.sigma_m = 0.25;
  return c;
}

SensorModelConfig SensorModelConfig::PaperHokuyo() {
  SensorModelConfig c;
  c.sigma_m = 0.1;
  return c;
}

void SensorModelConfig::Validate() const {
  KESTREL_THROW_UNLESS(std::isfinite(sigma_m) && sigma_m > 0.0,
                       "sensor model sigma_m = " << sigma_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(z_min_m) && z_min_m >= 0.0,
                       "sensor model z_min_m = " << z_min_m << ", accepted [0, z_max_m)");
  KESTREL_THROW_UNLESS(
      std::isfinite(z_max_m) && z_max_m > z_min_m,
      "sensor model z_max_m = " << z_max_m << ", accepted (z_min_m = " << z_min_m << ", inf)");
  KESTREL_THROW_UNLESS(p_rand > 0.0 && p_rand < 1.0,
                       "sensor model p_rand = " << p_rand << ", accepted (0, 1)");
  KESTREL_THROW_UNLESS(p_miss > 0.0 && p_miss < 1.0,
                       "sensor model p_miss = " << p_miss << ", accepted (0, 1)");
  KESTREL_THROW_UNLESS(cutoff_sigmas >= 5.0,
                       "sensor model cutoff_sigmas = " << cutoff_sigmas << ", accepted [5, inf]");
  KESTREL_THROW_UNLESS(direction_uncertainty_rad >= 0.0 && direction_uncertainty_rad <= 0.2,
                       "sensor model direction_uncertainty_rad = " << direction_uncertainty_rad
                                                                   << ", accepted [0, 0.2]");
  KESTREL_THROW_UNLESS(
      band_surface_max_m >= 0.0,
      "sensor model band_surface_max_m = " << band_surface_max_m << ", accepted [0, inf]");
}

SensorModel::SensorModel(const SensorModelConfig& config) : config_(config) {
  config_.Validate();
  uniform_density_ = 1.0 / (config_.z_max_m - config_.z_min_m);
  spurious_density_ = config_.p_rand * uniform_density_;
  gaussian_scale_ =
      (1.0 - config_.p_rand) * (1.0 - config_.p_miss) / (config_.sigma_m * std::sqrt(2.0 * M_PI));
  inv_sigma2_ = 1.0 / (config_.sigma_m * config_.sigma_m);
  inv_sigma_sqrt2_ = 1.0 / (config_.sigma_m * std::sqrt(2.0));
  inv_sigma_sqrt_2pi_ = 1.0 / (config_.sigma_m * std::sqrt(2.0 * M_PI));
  cutoff_m_ = config_.cutoff_sigmas * config_.sigma_m;
  in_range_no_return_ = (1.0 - config_.p_rand) * config_.p_miss;
  if (config_.interpolated_gaussian && std::isfinite(config_.cutoff_sigmas)) {
    // exp(-x^2/2) at nodes x = i/512, slope -x exp(-x^2/2) (times the step).
    constexpr double kStepX = 1.0 / 512.0;
    const size_t nx = static_cast<size_t>(std::ceil(config_.cutoff_sigmas / kStepX)) + 2;
    const auto gauss = [&](size_t i, double* y, double* m) {
      const double x = static_cast<double>(i) * kStepX;
      *y = std::exp(-0.5 * x * x);
      *m = -x * *y * kStepX;
    };
    for (size_t i = 0; i + 1 < nx; ++i) {
      double y0, m0, y1, m1;
      gauss(i, &y0, &m0);
      gauss(i + 1, &y1, &m1);
      AppendInterval(y0, m0, y1, m1, &gaussian_table_);
    }
    gaussian_last_ = nx - 2;
    gaussian_index_per_m_ = 1.0 / (config_.sigma_m * kStepX);
    // 1/D(d) at nodes d = z_min + i h, h = sigma/256; slope -D'/D^2 (times h) with
    // D'(d) = (phi((z_min - d)/sigma) - phi((z_max - d)/sigma)) / sigma.
    const double h = config_.sigma_m / 256.0;
    const size_t nd = static_cast<size_t>(std::ceil((config_.z_max_m - config_.z_min_m) / h)) + 2;
    const auto phi = [](double x) { return std::exp(-0.5 * x * x) / std::sqrt(2.0 * M_PI); };
    const auto inv_mass = [&](size_t i, double* y, double* m) {
      const double d = config_.z_min_m + static_cast<double>(i) * h;
      const double mass = TruncationMass(d);
      const double slope = (phi((config_.z_min_m - d) / config_.sigma_m) -
                            phi((config_.z_max_m - d) / config_.sigma_m)) /
                           config_.sigma_m;
      *y = 1.0 / mass;
      *m = -slope / (mass * mass) * h;
    };
    for (size_t i = 0; i + 1 < nd; ++i) {
      double y0, m0, y1, m1;
      inv_mass(i, &y0, &m0);
      inv_mass(i + 1, &y1, &m1);
      AppendInterval(y0, m0, y1, m1, &inv_mass_table_);
    }
    mass_last_ = nd - 2;
    mass_index_per_m_ = 1.0 / h;
  }
}

double ReturnLikelihoodEvaluator::Direct(double r, double d_m) const {
  // Section 3: p_rand u + (1 - p_rand)(1 - p_miss) G_k(z), direct.
  return spurious_density_ + model_->DirectGaussianTerm(r, d_m);
}

double ReturnLikelihoodEvaluator::DirectBanded(double r, double d_m, double band_scale) const {
  return spurious_density_ + band_scale * model_->DirectGaussianTerm(r, d_m);
}

bool SensorModel::FillLikelihoods(const Reading* readings, int count, const double* distance_m,
                                  int rows, double* likelihood,
                                  const kernels::Kernels& kernels) const {
  static_assert(lanes::kLanes == 8, "one AVX-512 register of doubles per row");
  KESTREL_THROW_UNLESS(count >= 0 && count <= lanes::kLanes && rows >= 0,
                       "FillLikelihoods: count = " << count << ", rows = " << rows
                                                   << ", accepted count in [0, 8], rows >= 0");
  if (kernels.fill_likelihoods == nullptr || gaussian_table_.empty()) return false;
  alignas(64) double lo[lanes::kLanes] = {};
  alignas(64) double z[lanes::kLanes] = {};
  alignas(64) double scale[lanes::kLanes] = {};
  unsigned is_return = 0;
  for (int l = 0; l < count; ++l) {
    const Reading& r = readings[l];
    if (r.kind == ReadingKind::kReturn) {
      // Without a band: lo = z and the plain height (times 1, the same bits).
      lo[l] = r.z_m - r.below_m;
      z[l] = r.z_m;
      scale[l] = gaussian_scale_ * BandScale(r);
      is_return |= 1u << l;
    }
  }
  const ReturnLikelihoodEvaluator e = ReturnEvaluator();
  const kernels::LikelihoodLanes c{e.gaussian_table_,
                                   e.inv_mass_table_,
                                   static_cast<double>(e.gaussian_last_),
                                   static_cast<double>(e.mass_last_),
                                   e.gaussian_index_per_m_,
                                   e.mass_index_per_m_,
                                   config_.z_min_m,
                                   config_.z_max_m,
                                   e.cutoff_m_,
                                   e.spurious_density_,
                                   e.gaussian_scale_,
                                   1.0 - config_.p_rand,
                                   in_range_no_return_};
  kernels.fill_likelihoods(c, lo, z, scale, is_return, distance_m, rows, likelihood);
  return true;
}

Reading SensorModel::Classify(double range_m) const {
  if (std::isnan(range_m) || range_m < config_.z_min_m) return {ReadingKind::kInvalid, 0.0};
  if (range_m >= config_.z_max_m) return {ReadingKind::kNoReturn, 0.0};
  return {ReadingKind::kReturn, range_m};
}

double SensorModel::TruncationMass(double d_m) const {
  // 1 - Q_upper - Q_lower with Q(x) = erfc(x/sqrt 2)/2, the tails above z_max and below z_min.
  // Beyond 9 sigma a tail is below 1.2e-19 and cannot change 1 - (other tail) in double.
  const double upper = (config_.z_max_m - d_m) * inv_sigma_sqrt2_;  // (z_max - d)/(sigma sqrt 2)
  const double lower = (d_m - config_.z_min_m) * inv_sigma_sqrt2_;  // (d - z_min)/(sigma sqrt 2)
  constexpr double kNegligible = 9.0 / 1.4142135623730951;
  const double q_upper = upper > kNegligible ? 0.0 : 0.5 * std::erfc(upper);
  const double q_lower = lower > kNegligible ? 0.0 : 0.5 * std::erfc(lower);
  return 1.0 - q_upper - q_lower;
}

}  // namespace kestrel
