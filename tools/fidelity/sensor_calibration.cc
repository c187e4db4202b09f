#include "tools/fidelity/sensor_calibration.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace kestrel {

SensorCalibrator::SensorCalibrator(double z_min_m, double z_max_m, double window_m)
    : z_min_(z_min_m), z_max_(z_max_m), window_(window_m) {
  if (!(z_min_m >= 0.0 && z_max_m > z_min_m && std::isfinite(z_max_m))) {
    throw std::invalid_argument("SensorCalibrator: z_min_m = " + std::to_string(z_min_m) +
                                ", z_max_m = " + std::to_string(z_max_m) +
                                ", accepted 0 <= z_min < z_max, finite");
  }
  if (!(window_m > 10 * kBinM && window_m < z_max_m)) {
    throw std::invalid_argument("SensorCalibrator: window_m = " + std::to_string(window_m) +
                                ", accepted (0.005, z_max)");
  }
  const size_t bins = 2 * static_cast<size_t>(std::ceil(window_ / kBinM));
  cell_residuals_.assign(bins, 0);
  surface_residuals_.assign(bins, 0);
}

void SensorCalibrator::Add(double true_range_m, double cell_range_m, bool returned, double z_m) {
  const bool in_range = cell_range_m >= z_min_ && cell_range_m < z_max_;
  if (!in_range) {
    if (!out_of_range_rays_seen_) return;
    ++out_of_range_;
    if (returned) ++out_of_range_returns_;
    return;
  }
  ++in_range_;
  if (!returned) return;
  ++in_range_returns_;
  const auto bin_of = [&](double r) -> int64_t {
    if (!(std::abs(r) < window_)) return -1;
    const auto b = static_cast<int64_t>(std::floor((r + window_) / kBinM));
    return b >= 0 && b < static_cast<int64_t>(cell_residuals_.size()) ? b : -1;
  };
  const int64_t b = bin_of(z_m - cell_range_m);
  if (b < 0) {
    ++far_returns_;
  } else {
    ++cell_residuals_[static_cast<size_t>(b)];
  }
  const int64_t bs = std::isfinite(true_range_m) ? bin_of(z_m - true_range_m) : -1;
  if (bs >= 0) ++surface_residuals_[static_cast<size_t>(bs)];
}

namespace {

// EM for the in-window residual histogram `bins` (bin b centred at -window + (b + 0.5) bin_m),
// `far` returns beyond the window, `misses` in-range rays without a return, and the out-of-range
// rays. Writes sigma, p_rand, p_miss; returns the iteration count (negative: not converged).
int FitMixture(const std::vector<int64_t>& bins, double window, double bin_m, double u, int64_t far,
               int64_t misses, int64_t out_returns, int64_t out_rays, double* sigma, double* p_rand,
               double* p_miss) {
  double s = window / 10.0, pr = 0.1, pm = 0.1;
  double previous = -INFINITY;
  const double rays = static_cast<double>(out_rays) + static_cast<double>(far + misses) + [&] {
    double n = 0;
    for (int64_t c : bins) n += static_cast<double>(c);
    return n;
  }();
  constexpr int kMaxIterations = 500;
  for (int it = 1; it <= kMaxIterations; ++it) {
    double hits = 0.0, spurious = static_cast<double>(far), r2 = 0.0, log_likelihood = 0.0;
    const double gauss_weight = (1.0 - pr) * (1.0 - pm);
    const double norm = 1.0 / (std::sqrt(2.0 * M_PI) * s);
    for (size_t b = 0; b < bins.size(); ++b) {
      if (bins[b] == 0) continue;
      const double r = -window + (static_cast<double>(b) + 0.5) * bin_m;
      const double g = gauss_weight * norm * std::exp(-0.5 * r * r / (s * s));
      const double total = pr * u + g;
      const double gamma = total > 0.0 ? g / total : 0.0;
      const auto c = static_cast<double>(bins[b]);
      hits += c * gamma;
      spurious += c * (1.0 - gamma);
      r2 += c * gamma * r * r;
      log_likelihood += c * std::log(total);
    }
    log_likelihood += static_cast<double>(far) * std::log(pr * u) +
                      static_cast<double>(misses) * std::log((1.0 - pr) * pm) +
                      static_cast<double>(out_returns) * std::log(pr * u) +
                      static_cast<double>(out_rays - out_returns) * std::log(1.0 - pr);
    pr = (spurious + static_cast<double>(out_returns)) / rays;
    pm = static_cast<double>(misses) / (hits + static_cast<double>(misses));
    s = std::max(std::sqrt(r2 / hits), bin_m);
    pr = std::min(std::max(pr, 1e-9), 1.0 - 1e-9);
    pm = std::min(std::max(pm, 1e-9), 1.0 - 1e-9);
    if (std::abs(log_likelihood - previous) <= 1e-9 * std::abs(log_likelihood)) {
      *sigma = s, *p_rand = pr, *p_miss = pm;
      return it;
    }
    previous = log_likelihood;
  }
  *sigma = s, *p_rand = pr, *p_miss = pm;
  return -kMaxIterations;
}

}  // namespace

SensorCalibration SensorCalibrator::Fit() const {
  if (in_range_returns_ - far_returns_ <= 0) {
    throw std::runtime_error("SensorCalibrator: no return near a surface in range to fit");
  }
  SensorCalibration c;
  c.rays_in_range = in_range_;
  c.returns_in_range = in_range_returns_;
  c.rays_out_of_range = out_of_range_;
  c.returns_out_of_range = out_of_range_returns_;
  const double u = 1.0 / (z_max_ - z_min_);
  const int64_t misses = in_range_ - in_range_returns_;
  const int it = FitMixture(cell_residuals_, window_, kBinM, u, far_returns_, misses,
                            out_of_range_returns_, out_of_range_, &c.sigma_m, &c.p_rand, &c.p_miss);
  c.iterations = std::abs(it);
  c.converged = it > 0;
  // The same fit about the true range, for the sigma the surface alone gives (the returns that
  // fall outside the window about d but inside it about d_k count as far: a few at most).
  int64_t surface_in_window = 0;
  for (int64_t n : surface_residuals_) surface_in_window += n;
  double ignored_p_rand = 0.0, ignored_p_miss = 0.0;
  FitMixture(surface_residuals_, window_, kBinM, u, in_range_returns_ - surface_in_window, misses,
             out_of_range_returns_, out_of_range_, &c.sigma_surface_m, &ignored_p_rand,
             &ignored_p_miss);
  return c;
}

}  // namespace kestrel
