#pragma once
/// @file
/// Exact inverse sensor model, eqs. (2)-(4) of Kaufman et al. 2018 (ALGORITHMS.md section 4), in
/// O(n_r) per ray. Symbols:
///   P_k     prior of the k-th cell along the ray, Pbar_k = 1 - P_k
///   pi_k    = P_k prod_{j<k} Pbar_j        probability that cell k is the first occupied cell
///   a_k     = p(z | r_k+)                  forward model (mapping/sensor_model.h)
///   S_k     = sum_{i<=k} pi_i a_i          prefix sums, S_0 = 0
///   1/eta   = S_nr + pi_(nr+1) a_(nr+1)    = p(z), eq. (4)
///   P'_k    = eta (P_k S_(k-1) + pi_k a_k)  posterior, eqs. (2)-(3)
/// One forward pass accumulates pi and S in double; a second writes P'_k.
///
/// Which cells are written (ALGORITHMS.md sections 3 and 4):
///  - a return z updates every cell of the ray, except that cells with d_k > z + c*sigma are left
///    out (the allowed shortcut; exact under the model's Gaussian window, see sensor_model.h), and
///    1/eta is completed with p_rand * u * prod_{j<=K} Pbar_j, K the last cell kept;
///  - "no return" updates the cells with d_k >= z_min only; the near cells still enter the
///    marginalisation (their priors weigh pi), but their posteriors are not written, so that
///    facing open space never grows phantom obstacles near the sensor.
/// Posteriors are returned unclamped; the map clamps them to [P_min, 1 - P_min].

#include <cstdint>
#include <vector>

#include "common/check.h"
#include "mapping/sensor_model.h"

namespace kestrel {

/// Caller-owned per-ray scratch (prefix sums), sized once; no allocation per ray.
class InverseSensorModelScratch {
 public:
  /// Scratch for rays of up to `capacity` cells.
  explicit InverseSensorModelScratch(int capacity)
      : s_before_(static_cast<size_t>(capacity)),
        first_term_(static_cast<size_t>(capacity)),
        prior_(static_cast<size_t>(capacity)) {}
  /// Largest n_r this scratch holds.
  [[nodiscard]] int capacity() const { return static_cast<int>(s_before_.size()); }
  /// Cells visited by ComputeExactPosteriors since construction (both passes): the work counter
  /// the linear-cost test reads.
  [[nodiscard]] uint64_t cell_visits() const { return cell_visits_; }

 private:
  friend struct ExactUpdate;
  std::vector<double> s_before_;    // S_(k-1)
  std::vector<double> first_term_;  // pi_k a_k
  std::vector<double> prior_;       // P_k as read in the forward pass
  uint64_t cell_visits_{0};
};

/// The cells a call wrote: posterior[first .. first + count), and p(z).
struct ExactUpdateResult {
  int first{0};         ///< index of the first cell written
  int count{0};         ///< number of cells written
  double inv_eta{0.0};  ///< 1/eta = p(z) (a density, 1/m, for a return; a probability otherwise)
};

/// The exact update as a pure function (a struct only to befriend the scratch).
struct ExactUpdate {
  /// Computes P'_k for the cells of one ray (file comment for which cells).
  /// @param model       forward model of the sensor
  /// @param reading     kReturn or kNoReturn (kInvalid readings must be dropped by the caller)
  /// @param distance_m  d_1..d_n, m, non-decreasing (mapping/ray_caster.h)
  /// @param prior       P_1..P_n, each in [0, 1]
  /// @param n           n_r (0 allowed), at most scratch->capacity()
  /// @param posterior   out: P'_k written for k in [result.first, result.first + result.count)
  /// @param scratch     caller-owned scratch
  /// @throws std::invalid_argument on a kInvalid reading or n out of range.
  static ExactUpdateResult ComputeExactPosteriors(const SensorModel& model, const Reading& reading,
                                                  const double* distance_m, const double* prior,
                                                  int n, double* posterior,
                                                  InverseSensorModelScratch* scratch);

  /// The same computation with the priors read through prior_at(k) -> double (once per cell, in
  /// order) and each posterior handed to write(k, P'_k) (in order), so that a map can read and
  /// write its cells in place without staging arrays. `likelihood`, if not null, holds a_k for
  /// the cells used (as ForwardLikelihoods computes them, e.g. on another thread).
  /// @throws std::invalid_argument on a kInvalid reading or n out of range.
  template <class PriorAt, class Write>
  static ExactUpdateResult Apply(const SensorModel& model, const Reading& reading,
                                 const double* distance_m, int n, PriorAt&& prior_at, Write&& write,
                                 InverseSensorModelScratch* scratch,
                                 const double* likelihood = nullptr);

  /// The cells a reading uses (the shortcut's cut for a return, all for "no return"), and their
  /// a_k written to likelihood[0 .. returned count). Reads no map.
  static int ForwardLikelihoods(const SensorModel& model, const Reading& reading,
                                const double* distance_m, int n, double* likelihood);

 private:
  static void CheckInput(const Reading& reading, int n, const InverseSensorModelScratch* scratch);
};

/// Convenience alias of ExactUpdate::ComputeExactPosteriors.
inline ExactUpdateResult ComputeExactPosteriors(const SensorModel& model, const Reading& reading,
                                                const double* distance_m, const double* prior,
                                                int n, double* posterior,
                                                InverseSensorModelScratch* scratch) {
  return ExactUpdate::ComputeExactPosteriors(model, reading, distance_m, prior, n, posterior,
                                             scratch);
}

// ---------------------------------------------------------------------------------------------
// Implementation.

template <class PriorAt, class Write>
ExactUpdateResult ExactUpdate::Apply(const SensorModel& model, const Reading& reading,
                                     const double* distance_m, int n, PriorAt&& prior_at,
                                     Write&& write, InverseSensorModelScratch* scratch,
                                     const double* likelihood) {
  CheckInput(reading, n, scratch);
  ExactUpdateResult result;
  double* const s_before = scratch->s_before_.data();
  double* const first_term = scratch->first_term_.data();
  double* const prior = scratch->prior_.data();
  double s = 0.0;         // S_k
  double pbar_run = 1.0;  // prod_{j<=k} Pbar_j
  int end = n;
  if (reading.kind == ReadingKind::kReturn) {
    const double z = reading.z_m;
    const double reach_m = model.GaussianReach(z);
    // Shortcut: cells with d_k > z + c sigma are left out (ALGORITHMS.md section 4).
    while (end > 0 && distance_m[end - 1] > reach_m) --end;
    for (int k = 0; k < end; ++k) {
      const double p = prior_at(k);
      KESTREL_ASSERT(p >= 0.0 && p <= 1.0);
      prior[k] = p;
      const double pi = p * pbar_run;  // pi_k
      const double a =
          likelihood != nullptr ? likelihood[k] : model.ReturnLikelihood(z, distance_m[k]);
      const double term = pi * a;  // pi_k a_k
      s_before[k] = s;             // S_(k-1)
      first_term[k] = term;
      s += term;  // S_k
      pbar_run *= 1.0 - p;
    }
    result.inv_eta = s + pbar_run * model.spurious_density();  // eq. (4), completed tail
  } else {
    for (int k = 0; k < end; ++k) {
      const double p = prior_at(k);
      KESTREL_ASSERT(p >= 0.0 && p <= 1.0);
      prior[k] = p;
      const double pi = p * pbar_run;  // pi_k
      const double a =
          likelihood != nullptr ? likelihood[k] : model.NoReturnProbability(distance_m[k]);
      const double term = pi * a;  // pi_k a_k
      s_before[k] = s;             // S_(k-1)
      first_term[k] = term;
      s += term;  // S_k
      pbar_run *= 1.0 - p;
    }
    result.inv_eta = s + pbar_run * model.empty_no_return_probability();  // eq. (4)
    // Only cells with d_k >= z_min are written (ALGORITHMS.md section 3).
    const double z_min = model.config().z_min_m;
    while (result.first < end && distance_m[result.first] < z_min) ++result.first;
  }
  KESTREL_DEMAND(result.inv_eta > 0.0);
  const double eta = 1.0 / result.inv_eta;
  for (int k = result.first; k < end; ++k) {
    write(k, eta * (prior[k] * s_before[k] + first_term[k]));  // eqs. (2)-(3)
  }
  result.count = end - result.first;
  scratch->cell_visits_ += static_cast<uint64_t>(end) + static_cast<uint64_t>(result.count);
  return result;
}

/// Clamps p to [p_min, 1 - p_min] (ALGORITHMS.md section 1).
[[nodiscard]] inline double ClampProbability(double p, double p_min) {
  return p < p_min ? p_min : (p > 1.0 - p_min ? 1.0 - p_min : p);
}

}  // namespace kestrel
