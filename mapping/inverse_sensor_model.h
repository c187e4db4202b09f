#pragma once
/// @file
/// Exact inverse sensor model, eqs. (2)-(4) of Kaufman et al. 2018 (docs/algorithms.md §4.1), in
/// O(n_r) per ray. Symbols:
///   P_k     prior of the k-th cell along the ray, Pbar_k = 1 - P_k
///   pi_k    = P_k prod_{j<k} Pbar_j        probability that cell k is the first occupied cell
///   a_k     = p(z | r_k+)                  forward model (mapping/sensor_model.h)
///   S_k     = sum_{i<=k} pi_i a_i          prefix sums, S_0 = 0
///   1/eta   = S_nr + pi_(nr+1) a_(nr+1)    = p(z), eq. (4)
///   P'_k    = eta (P_k S_(k-1) + pi_k a_k)  posterior, eqs. (2)-(3)
/// One forward pass accumulates pi and S in double; a second writes P'_k, computed as
/// eta P_k C_k with C_k = S_(k-1) + Pbar_(k-1) a_k (the same value; see ExactUpdate::Apply).
///
/// Which cells are written (docs/algorithms.md §3.5, §4.2):
///  - a return z updates every cell of the ray, except that cells with d_k > z + c*sigma are left
///    out (the allowed shortcut; exact under the model's Gaussian window, see sensor_model.h), and
///    1/eta is completed with p_rand * u * prod_{j<=K} Pbar_j, K the last cell kept;
///  - "no return" updates the cells with d_k >= z_min only; the near cells still enter the
///    marginalisation (their priors weigh pi), but their posteriors are not written, so that
///    facing open space never grows phantom obstacles near the sensor.
/// Posteriors are returned unclamped; the map clamps them to [P_min, 1 - P_min].

#include <algorithm>
#include <cstdint>
#include <vector>

#include "common/check.h"
#include "mapping/lanes.h"
#include "mapping/sensor_model.h"

namespace kestrel {

/// Caller-owned per-ray scratch (prefix sums), sized once; no allocation per ray.
class InverseSensorModelScratch {
 public:
  /// Scratch for rays of up to `capacity` cells.
  explicit InverseSensorModelScratch(int capacity)
      : c_term_(static_cast<size_t>(capacity)), prior_(static_cast<size_t>(capacity)) {}
  /// Largest n_r this scratch holds.
  [[nodiscard]] int capacity() const { return static_cast<int>(c_term_.size()); }
  /// Cells visited by ComputeExactPosteriors since construction (both passes): the work counter
  /// the linear-cost test reads.
  [[nodiscard]] uint64_t cell_visits() const { return cell_visits_; }

 private:
  friend struct ExactUpdate;
  std::vector<double> c_term_;  // C_k = S_(k-1) + Pbar_(k-1) a_k (ExactUpdate::Apply)
  std::vector<double> prior_;   // P_k as read in the forward pass
  uint64_t cell_visits_{0};
};

/// One lane of a RayBatch's arrays (ray_caster.h) seen as a ray's own array: element k is
/// data[k * lanes::kLanes]. A null view stands for "not filled" (as a null pointer does).
struct LaneView {
  const double* data{nullptr};  ///< the lane's first element
  /// Element k of the lane.
  double operator[](int k) const { return data[static_cast<ptrdiff_t>(k) * lanes::kLanes]; }
  /// Whether the view holds values.
  explicit operator bool() const { return data != nullptr; }
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
  /// `distance_m` and `likelihood` are indexed with [k]: pointers, or LaneViews into a RayBatch.
  /// @throws std::invalid_argument on a kInvalid reading or n out of range.
  template <class Distance, class PriorAt, class Write, class Likelihood = const double*>
  static ExactUpdateResult Apply(const SensorModel& model, const Reading& reading,
                                 const Distance& distance_m, int n, PriorAt&& prior_at,
                                 Write&& write, InverseSensorModelScratch* scratch,
                                 Likelihood likelihood = nullptr);

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

template <class Distance, class PriorAt, class Write, class Likelihood>
ExactUpdateResult ExactUpdate::Apply(const SensorModel& model, const Reading& reading,
                                     const Distance& distance_m, int n, PriorAt&& prior_at,
                                     Write&& write, InverseSensorModelScratch* scratch,
                                     Likelihood likelihood) {
  // Eqs. (2)-(3) rewritten: P_k S_(k-1) + pi_k a_k = P_k (S_(k-1) + Pbar_(k-1) a_k) = P_k C_k,
  // so P'_k = eta P_k C_k with C_k = S_(k-1) + Pbar_(k-1) a_k (a sum of non-negative terms, no
  // cancellation). Over a leading run of cells whose a_k is the same constant A (for a return:
  // cells nearer than z_min or more than c sigma before z, where a_k = p_rand u), S_(k-1) =
  // A (1 - Pbar_(k-1)), hence C_k = A exactly and P'_k = (eta A) P_k: those cells need neither
  // a_k nor a stored C_k, which is most of a ray (docs/algorithms.md §4.3).
  CheckInput(reading, n, scratch);
  ExactUpdateResult result;
  double* const c_term = scratch->c_term_.data();  // C_k
  double* const prior = scratch->prior_.data();    // P_k as read in the forward pass
  double s = 0.0;                                  // S_k
  double pbar_run = 1.0;                           // prod_{j<=k} Pbar_j = Pbar_k
  int end = n;
  int run_end = 0;     // cells [0, run_end) form the leading run with a_k = run_a
  double run_a = 0.0;  // A of the leading run
  double tail_a;       // a_(nr+1), the empty ray's likelihood
  if (reading.kind == ReadingKind::kReturn) {
    const double z = reading.z_m;
    // Shortcut: cells with d_k > z + c sigma are left out (docs/algorithms.md §4.2).
    const double reach_m = model.GaussianReach(z);
    while (end > 0 && distance_m[end - 1] > reach_m) --end;
    run_a = model.spurious_density();
    double pi_sum = 0.0;  // sum_{i<=k} pi_i over the run
    while (run_end < end && model.SpuriousOnly(z, distance_m[run_end])) {
      const double p = prior_at(run_end);
      KESTREL_ASSERT(p >= 0.0 && p <= 1.0);
      prior[run_end] = p;
      pi_sum += p * pbar_run;  // pi_k
      pbar_run *= 1.0 - p;
      ++run_end;
    }
    s = run_a * pi_sum;  // S_k over the run: sum pi_i A
    // The Gaussian window: a_k per cell (precomputed, or evaluated with the model's constants
    // held in registers).
    const auto window = [&](auto&& a_of) {
      for (int k = run_end; k < end; ++k) {
        const double p = prior_at(k);
        KESTREL_ASSERT(p >= 0.0 && p <= 1.0);
        prior[k] = p;
        const double pbar_a = pbar_run * a_of(k);  // Pbar_(k-1) a_k
        c_term[k] = s + pbar_a;                    // C_k
        s += p * pbar_a;                           // S_k = S_(k-1) + pi_k a_k
        pbar_run *= 1.0 - p;
      }
    };
    if (likelihood) {
      window([likelihood](int k) { return likelihood[k]; });
    } else {
      const ReturnLikelihoodEvaluator a_k = model.ReturnEvaluator();
      window([&a_k, z, &distance_m](int k) { return a_k(z, distance_m[k]); });
    }
    tail_a = model.spurious_density();  // eq. (4), completed tail: p_rand u prod Pbar
  } else {
    for (int k = 0; k < end; ++k) {
      const double p = prior_at(k);
      KESTREL_ASSERT(p >= 0.0 && p <= 1.0);
      prior[k] = p;
      const double a = likelihood ? likelihood[k] : model.NoReturnProbability(distance_m[k]);
      const double pbar_a = pbar_run * a;  // Pbar_(k-1) a_k
      c_term[k] = s + pbar_a;              // C_k
      s += p * pbar_a;                     // S_k
      pbar_run *= 1.0 - p;
    }
    tail_a = model.empty_no_return_probability();
    // Only cells with d_k >= z_min are written (docs/algorithms.md §3.5).
    const double z_min = model.config().z_min_m;
    while (result.first < end && distance_m[result.first] < z_min) ++result.first;
  }
  result.inv_eta = s + pbar_run * tail_a;  // eq. (4)
  KESTREL_DEMAND(result.inv_eta > 0.0);
  const double eta = 1.0 / result.inv_eta;
  const double run_ratio = eta * run_a;  // P'_k / P_k over the leading run
  for (int k = result.first; k < run_end; ++k) write(k, run_ratio * prior[k]);
  for (int k = std::max(result.first, run_end); k < end; ++k) {
    write(k, eta * (c_term[k] * prior[k]));  // eqs. (2)-(3): eta P_k C_k
  }
  result.count = end - result.first;
  scratch->cell_visits_ += static_cast<uint64_t>(end) + static_cast<uint64_t>(result.count);
  return result;
}

/// Clamps p to [p_min, 1 - p_min] (docs/algorithms.md §1.2). Precondition: p not NaN (then the
/// min/max form compiles to two instructions).
[[nodiscard]] inline double ClampProbability(double p, double p_min) {
  const double upper = 1.0 - p_min;
  const double below_upper = upper < p ? upper : p;
  return below_upper < p_min ? p_min : below_upper;
}

}  // namespace kestrel
