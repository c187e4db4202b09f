#pragma once
/// @file
/// Sensor-model calibration (docs/algorithms.md §3.7): the maximum-likelihood sigma, p_rand and
/// p_miss of the forward model of docs/algorithms.md §3.2 from rays whose true first surface is
/// known (the simulator's world, or a surveyed map). Pure: the samples in, the fit out.
///
/// Each ray is one of two kinds by d_k, the model's distance of the ray's first occupied cell
/// (its chord midpoint, docs/algorithms.md §2.2) in the true world voxelised on the map's lattice:
///  - d_k in [z_min, z_max): the reading is a hit z ~ N(d_k, sigma^2) with probability
///    (1 - p_rand)(1 - p_miss), a miss ("no return") with (1 - p_rand) p_miss, or a spurious
///    return uniform on [z_min, z_max) with p_rand;
///  - otherwise: a spurious return with p_rand, else "no return".
/// The fitted sigma therefore holds all that the model's Gaussian has to explain: the sensor's
/// noise, the pose's, where in its cell the surface lies, and the rays that graze a cell the
/// truth holds occupied before they reach the surface. EM on the mixture of the Gaussian and the
/// uniform gives the three values; the residuals z - d_k are kept in a histogram (0.5 mm bins), so
/// memory does not grow with the log.

#include <cstdint>
#include <vector>

namespace kestrel {

/// The fitted values and the counts behind them.
struct SensorCalibration {
  double sigma_m{0.0};          ///< Gaussian sigma about d_k, m
  double p_rand{0.0};           ///< spurious-return probability
  double p_miss{0.0};           ///< probability an in-range surface gives no return
  double sigma_surface_m{0.0};  ///< sigma about the true range d (no cell term), m, for reference
  int64_t rays_in_range{0};     ///< rays with d in [z_min, z_max)
  int64_t returns_in_range{0};  ///< of those, returns
  int64_t rays_out_of_range{0};
  int64_t returns_out_of_range{0};  ///< spurious by definition
  int iterations{0};
  bool converged{false};
};

/// Accumulates rays and fits the model to them.
class SensorCalibrator {
 public:
  /// z_min, z_max: the model's range limits (0 <= z_min < z_max); residuals beyond
  /// +-window_m are certainly not Gaussian hits and count as spurious returns.
  /// @throws std::invalid_argument on bad limits or window.
  SensorCalibrator(double z_min_m, double z_max_m, double window_m = 1.0);

  /// For a sensor whose no-return is no evidence (docs/algorithms.md §3.4: the mapper drops it,
  /// so the caller never sees it): a ray whose d_k lies out of range would show only when it
  /// returned, every one of them spurious, so Add leaves such rays out.
  void LeaveOutOutOfRangeRays() { out_of_range_rays_seen_ = false; }

  /// One ray with its true range d to the surface (+infinity: none within z_max; used only for
  /// sigma_surface_m) and d_k (+infinity: no occupied cell within z_max), and its reading: a
  /// return at z_m, or no return when `returned` is false.
  void Add(double true_range_m, double cell_range_m, bool returned, double z_m);

  /// The maximum-likelihood fit (EM from sigma = window / 10, p_rand = 0.1, p_miss = 0.1 until
  /// the log-likelihood changes by less than 1e-9 relative). Needs at least one in-range return.
  /// @throws std::runtime_error when there is nothing to fit.
  [[nodiscard]] SensorCalibration Fit() const;

 private:
  double z_min_, z_max_, window_;
  bool out_of_range_rays_seen_{true};
  static constexpr double kBinM = 0.0005;
  std::vector<int64_t> cell_residuals_;     // z - d_k, bins of kBinM over [-window, window]
  std::vector<int64_t> surface_residuals_;  // z - d, the same bins
  int64_t far_returns_{0};                  // in-range rays whose return lies beyond the window
  int64_t in_range_{0}, in_range_returns_{0}, out_of_range_{0}, out_of_range_returns_{0};
};

}  // namespace kestrel
