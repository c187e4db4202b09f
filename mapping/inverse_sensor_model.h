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
/// (eta C_k) P_k with C_k = S_(k-1) + Pbar_(k-1) a_k (the same value; see ExactUpdate::Apply).
/// C_k is one constant over a run of cells with the same a_k, and the forward pass's products and
/// sums are formed in blocks of eight cells in a fixed order (docs/algorithms.md §4.7): the
/// canonical arithmetic every instruction set's kernels follow, so maps are bit-identical.
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
      : scale_(static_cast<size_t>(capacity)), prior_(static_cast<size_t>(capacity)) {}
  /// Largest n_r this scratch holds.
  [[nodiscard]] int capacity() const { return static_cast<int>(scale_.size()); }
  /// Cells visited by the updates since construction (both passes): the work counter the
  /// linear-cost test reads.
  [[nodiscard]] uint64_t cell_visits() const { return cell_visits_; }
  /// eta C_k of the cells of the last ExactUpdate::Forward's per-cell segment (ExactForward).
  [[nodiscard]] const double* scale() const { return scale_.data(); }

 private:
  friend struct ExactUpdate;
  std::vector<double> scale_;  // C_k, then eta C_k (ExactUpdate::Forward)
  std::vector<double> prior_;  // P_k as read in the forward pass (ExactUpdate::Apply)
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

/// What ExactUpdate::Forward leaves for the write step: the cells written, [first, end), get
/// P'_k = scale_k P_k (then clamped), in up to three segments in cell order. A segment of cells
/// with the same a_k (a run) has one scale, eta C_run; the Gaussian window's cells each have
/// their own, eta C_k, in InverseSensorModelScratch::scale()[k] (docs/algorithms.md §4.7).
struct ExactForward {
  /// Cells [begin, end) of a segment.
  struct Segment {
    int begin{0};          ///< first cell
    int end{0};            ///< one past the last cell
    double scale{0.0};     ///< eta C_run for a run
    bool per_cell{false};  ///< scale_k in the scratch's scale()[k] instead
  };
  Segment segments[3];   ///< in cell order, covering [first, end)
  int segment_count{0};  ///< segments in use
  int first{0};          ///< index of the first cell written
  int end{0};            ///< one past the last cell written (the shortcut's cut for a return)
  double inv_eta{0.0};   ///< 1/eta = p(z)
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

  /// The forward pass of Apply (docs/algorithms.md §4.1, §4.7): reads P_k through prior_at(k)
  /// (once per cell, in order) and returns the scale of every cell written, for a write step
  /// that computes P'_k = scale_k P_k itself (ExactBayesUpdater's kernels). Arguments as Apply's.
  /// @throws std::invalid_argument on a kInvalid reading or n out of range.
  template <class Distance, class PriorAt, class Likelihood = const double*>
  static ExactForward Forward(const SensorModel& model, const Reading& reading,
                              const Distance& distance_m, int n, PriorAt&& prior_at,
                              InverseSensorModelScratch* scratch, Likelihood likelihood = nullptr);

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

// The canonical order of the forward pass (docs/algorithms.md §4.7). Eqs. (2)-(3) rewritten:
// P_k S_(k-1) + pi_k a_k = P_k (S_(k-1) + Pbar_(k-1) a_k) = P_k C_k, so P'_k = (eta C_k) P_k with
// C_k = S_(k-1) + Pbar_(k-1) a_k (a sum of non-negative terms, no cancellation). Over a run of
// cells whose a_k is one constant A, entered with S and Pbar (the sum and product of the cells
// before it), S_(k-1) = S + A Pbar (1 - prod_run Pbar_j), hence C_k = S + A Pbar for every cell of
// the run: a run needs neither a_k nor C_k per cell, only its sum T = sum_k P_k prod_{j<k} Pbar_j
// and product Q = prod_k Pbar_k. Runs: for a return the cells nearer than z_min or more than
// c sigma before z (a_k = p_rand u), most of a ray; for "no return" the cells below z_min, in
// range and beyond z_max (a_k = 1 - p_rand, (1 - p_rand) p_miss, 1 - p_rand). Only a return's
// Gaussian window has a_k per cell. Both kinds of segment are summed in blocks of eight cells from
// the segment's start: left to right inside a block, then block after block, so the loop-carried
// chain is one product and one sum per block instead of per cell.
// The first k in [begin, end) where holds(distance_m[k]) is false, for a predicate that holds on a
// prefix (d_k does not decrease): a binary search without branches on the data.
template <class Distance, class Holds>
int PrefixEnd(const Distance& distance_m, int begin, int end, const Holds& holds) {
  int base = begin, length = end - begin;  // the answer lies in [base, base + length]
  while (length > 1) {
    const int half = length / 2;
    base += holds(distance_m[base + half - 1]) ? half : 0;
    length -= half;
  }
  return base + (length == 1 && holds(distance_m[base]) ? 1 : 0);
}

// The cells a return uses, [0, end): for a surface_unknown return those before its band's near
// end (from there on every hypothesis explains it alike, so the cells keep their priors:
// docs/algorithms.md §3.8), otherwise those up to z + c sigma (the shortcut of
// docs/algorithms.md §4.2).
template <class Distance>
int ReturnCellsEnd(const SensorModel& model, const Reading& reading, const Distance& distance_m,
                   int n) {
  if (reading.surface_unknown) {
    const double lo = reading.z_m - reading.below_m;
    return PrefixEnd(distance_m, 0, n, [lo](double d) { return d < lo; });
  }
  const double reach_m = model.GaussianReach(reading.z_m);
  return PrefixEnd(distance_m, 0, n, [reach_m](double d) { return d <= reach_m; });
}

template <class Distance, class PriorAt, class Likelihood>
ExactForward ExactUpdate::Forward(const SensorModel& model, const Reading& reading,
                                  const Distance& distance_m, int n, PriorAt&& prior_at,
                                  InverseSensorModelScratch* scratch, Likelihood likelihood) {
  constexpr int kBlock = 8;
  CheckInput(reading, n, scratch);
  ExactForward f;
  double* const scale = scratch->scale_.data();  // C_k, then eta C_k (window)
  double s = 0.0;                                // S before the next segment
  double pbar = 1.0;                             // prod Pbar_j before the next segment
  double c_run[3] = {0.0, 0.0, 0.0};
  // A run of cells [begin, end) with a_k = a: S and Pbar move past it; its C_run is kept.
  const auto run = [&](int begin, int end, double a) {
    double t_run = 0.0;  // sum_k P_k prod_{j<k} Pbar_j over the run
    double q_run = 1.0;  // prod_k Pbar_k over the run
    for (int block = begin; block < end; block += kBlock) {
      const int block_end = std::min(block + kBlock, end);
      double t = 0.0, q = 1.0;
      for (int k = block; k < block_end; ++k) {
        const double p = prior_at(k);
        KESTREL_ASSERT(p >= 0.0 && p <= 1.0);
        t += p * q;
        q *= 1.0 - p;
      }
      t_run += q_run * t;
      q_run *= q;
    }
    ExactForward::Segment& seg = f.segments[f.segment_count];
    seg = ExactForward::Segment{begin, end, 0.0, false};
    c_run[f.segment_count++] = s + pbar * a;  // C_k of every cell of the run
    s += a * (pbar * t_run);
    pbar *= q_run;
  };
  // The Gaussian window [begin, end): C_k per cell, a_k from a_of(k).
  const auto window = [&](int begin, int end, auto&& a_of) {
    for (int block = begin; block < end; block += kBlock) {
      const int block_end = std::min(block + kBlock, end);
      double u = 0.0, q = 1.0;  // the block's S and prod Pbar before cell k, relative to its start
      for (int k = block; k < block_end; ++k) {
        const double p = prior_at(k);
        KESTREL_ASSERT(p >= 0.0 && p <= 1.0);
        const double w = q * a_of(k);
        scale[k] = u + w;
        u += p * w;
        q *= 1.0 - p;
      }
      for (int k = block; k < block_end; ++k) scale[k] = s + pbar * scale[k];  // C_k
      s += pbar * u;
      pbar *= q;
    }
    f.segments[f.segment_count++] = ExactForward::Segment{begin, end, 0.0, true};
  };
  double tail_a;  // a_(nr+1), the empty ray's likelihood
  if (reading.kind == ReadingKind::kReturn) {
    const double z = reading.z_m;
    const double lo = z - reading.below_m;  // z without a band
    f.end = ReturnCellsEnd(model, reading, distance_m, n);
    const int run_end =
        PrefixEnd(distance_m, 0, f.end, [&](double d) { return model.SpuriousOnly(lo, d); });
    run(0, run_end, model.spurious_density());
    if (run_end < f.end) {
      if (likelihood) {
        window(run_end, f.end, [likelihood](int k) { return likelihood[k]; });
      } else {
        // Without a band (lo = z, scale 1) Banded is the plain a_k, bit for bit.
        const ReturnLikelihoodEvaluator a_k = model.ReturnEvaluator();
        const double band_scale = model.BandScale(reading);
        window(run_end, f.end, [&a_k, lo, z, band_scale, &distance_m](int k) {
          return a_k.Banded(lo, z, band_scale, distance_m[k]);
        });
      }
    }
    // Eq. (4), completed tail: p_rand u prod Pbar (the plateau's height for surface_unknown).
    tail_a = model.EmptyRayLikelihood(reading);
  } else {
    // NoReturnProbability: in range [z_min, z_max) or not; d_k does not decrease.
    const double z_min = model.config().z_min_m, z_max = model.config().z_max_m;
    f.end = n;
    const int near_end = PrefixEnd(distance_m, 0, n, [z_min](double d) { return d < z_min; });
    const int in_range_end =
        PrefixEnd(distance_m, near_end, n, [z_max](double d) { return d < z_max; });
    const double out_of_range_a = model.empty_no_return_probability();  // 1 - p_rand
    run(0, near_end, out_of_range_a);
    if (in_range_end > near_end) run(near_end, in_range_end, model.NoReturnProbability(z_min));
    if (n > in_range_end) run(in_range_end, n, out_of_range_a);
    tail_a = model.empty_no_return_probability();
    // Only cells with d_k >= z_min are written (docs/algorithms.md §3.5): not the first run.
    f.first = near_end;
  }
  f.inv_eta = s + pbar * tail_a;  // eq. (4)
  KESTREL_DEMAND(f.inv_eta > 0.0);
  const double eta = 1.0 / f.inv_eta;
  // The segments written, their scales: eta C_run, or eta C_k per cell.
  int written = 0;
  for (int i = 0; i < f.segment_count; ++i) {
    ExactForward::Segment& seg = f.segments[i];
    seg.begin = std::max(seg.begin, f.first);
    if (seg.begin >= seg.end) continue;
    if (seg.per_cell) {
      for (int k = seg.begin; k < seg.end; ++k) scale[k] = eta * scale[k];
    } else {
      seg.scale = eta * c_run[i];
    }
    f.segments[written++] = seg;
  }
  f.segment_count = written;
  scratch->cell_visits_ += static_cast<uint64_t>(f.end) + static_cast<uint64_t>(f.end - f.first);
  return f;
}

template <class Distance, class PriorAt, class Write, class Likelihood>
ExactUpdateResult ExactUpdate::Apply(const SensorModel& model, const Reading& reading,
                                     const Distance& distance_m, int n, PriorAt&& prior_at,
                                     Write&& write, InverseSensorModelScratch* scratch,
                                     Likelihood likelihood) {
  double* const prior = scratch->prior_.data();  // P_k as read in the forward pass
  const ExactForward f = Forward(
      model, reading, distance_m, n,
      [&](int k) {
        const double p = prior_at(k);
        prior[k] = p;
        return p;
      },
      scratch, likelihood);
  // The write step, P'_k = scale_k P_k (ExactForward), as the map's kernels compute it.
  const double* const scale = scratch->scale();
  for (int i = 0; i < f.segment_count; ++i) {
    const ExactForward::Segment& seg = f.segments[i];
    for (int k = seg.begin; k < seg.end; ++k) {
      write(k, (seg.per_cell ? scale[k] : seg.scale) * prior[k]);
    }
  }
  return ExactUpdateResult{f.first, f.end - f.first, f.inv_eta};
}

/// Clamps p to [p_min, 1 - p_min] (docs/algorithms.md §1.2). Precondition: p not NaN (then the
/// min/max form compiles to two instructions).
[[nodiscard]] inline double ClampProbability(double p, double p_min) {
  const double upper = 1.0 - p_min;
  const double below_upper = upper < p ? upper : p;
  return below_upper < p_min ? p_min : below_upper;
}

}  // namespace kestrel
