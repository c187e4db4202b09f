#pragma once
/// @file
/// Expected information gain of a candidate pose, eqs. (7)-(10) of Kaufman et al. 2018 as
/// cleaned in docs/algorithms.md §6.
///
/// One candidate ray: cells 1..n with priors P_j, chords [entry_j, exit_j] and d_j (the chord
/// midpoint, exploration/ray_caster_2d.h). Hypothetical measurements k = 1..n: a return at
///     z_k = midpoint of chord_k intersected with [z_min, z_max)   (= d_k for a chord in range)
/// and k = n+1: "no return". For each:
///     P'_j(k) = posterior of cell j given measurement k, by the mapper's exact inverse sensor
///               model (mapping/inverse_sensor_model.h, docs/algorithms.md §4.1; the cells it
///               does not write keep their prior: those beyond z_k + c*sigma for a return, those
///               nearer than z_min for "no return", exactly as in the map)
///     H_k     = sum_j H(P'_j(k))
/// Weights (WeightMode::kChordProbability, the contract):
///     q_k     = sum_i pi_i P(z in chord_k cap [z_min, z_max) | r_i+)       (Phi differences of
///               the windowed Gaussian plus the uniform term; 0 for a chord wholly below z_min)
///     q_(n+1) = P(no return) = sum_i pi_i P(none | r_i+) + pi_(n+1) (1 - p_rand)
///     w_k     = q_k / sum_i q_i
/// WeightMode::kPaperLiteral is the paper's eq. (8): w_k proportional to 1/eta_k, the density
/// p(z_k) for a return and the probability P(no return) for k = n+1 (hypotheses with q_k = 0
/// get weight 0 in both modes: the sensor cannot return there).
///     E[H]  = sum_k w_k H_k                 (eq. 7)
///     I_ray = sum_j H(P_j) - E[H]           (eq. 10 restricted to the ray)
/// A ray that leaves the map before z_max has no cells beyond: returns beyond its last chord are
/// not hypotheses (the weights are normalised over the hypotheses that exist).
///
/// Two evaluations, equal to 1e-9 relative (test InformationGain.FastEqualsDirect):
///  - direct: one call of the mapper's ComputeExactPosteriors per hypothesis and q_k from every
///    cell with Phi: the (n+1)^2 computation of the paper.
///  - fast: the same algebra, its geometry-only terms precomputed in a RayKernel (shared by rays
///    with the same chords), with three exact shortcuts: (a) q_k only from cells whose Gaussian
///    window reaches chord_k (the model's window makes the rest exactly 0); (b) cells beyond
///    z_k + c*sigma keep their prior, so their entropy is a suffix sum; (c) cells before the first
///    cell whose a_j differs from the spurious density p_rand*u have P'_j = eta_k p_rand u P_j (a
///    common factor: S_(j-1) = p_rand u (1 - prod Pbar), so P_j S_(j-1) + pi_j a_j collapses), and
///    their entropy is summed once per distinct prior value.
/// Cost of fast: O(n (w + D)) per ray, w the cells inside the Gaussian window, D the distinct
/// prior values before it. The fast path evaluates the section 4 algebra itself (fused with the
/// entropy sums in ExpectedEntropy::Evaluate); only the direct path calls the mapper's
/// ComputeExactPosteriors, and the equality test ties the two.
///
/// The posterior of hypothesis k is taken at the single point z_k while its weight is the
/// probability of the whole chord: with cells much longer than sigma (map B) this snapping
/// differs from the unsnapped expectation (test ExpectedEntropyMatchesMonteCarlo; the figure in
/// docs/STATUS.md) and can make I_ray slightly negative on well-known rays.

#include <Eigen/Core>
#include <vector>

#include "exploration/grid_map_2d.h"
#include "exploration/ray_caster_2d.h"
#include "mapping/inverse_sensor_model.h"
#include "mapping/sensor_model.h"

namespace kestrel {

/// How the hypotheses of eq. (7) are weighted (file comment).
enum class WeightMode {
  kChordProbability,  ///< docs/algorithms.md §6.2: probability of the chord / of no return
  kPaperLiteral,      ///< the paper's eq. (8): normalised 1/eta_k
};

/// Which evaluation computes E[H] (file comment).
enum class GainMethod {
  kFast,    ///< exact shortcuts, O(n (w + D))
  kDirect,  ///< the paper's (n+1)^2 computation
};

/// How ExpectedEntropy::Evaluate sums the binary entropies of a hypothesis's posteriors.
enum class EntropySum {
  kScalar,  ///< BinaryEntropy cell by cell, in order (the default: the same bits everywhere)
  /// Eight cells at once where the CPU has AVX-512 (kernels::Best), with a log accurate to a
  /// few ulp and eight partial sums (also for the chord weights q_k): equal to kScalar to ~1e-15
  /// relative, not bit for bit, and the bits depend on the instruction set. Elsewhere kScalar.
  kLanes,
};

/// The prior entropy of a ray and its expected posterior entropy, nats.
struct RayEntropy {
  double prior_entropy_nats{0.0};     ///< sum_j H(P_j)
  double expected_entropy_nats{0.0};  ///< E[H], eq. (7)
  /// I_ray = prior - expected, eq. (10) restricted to the ray, nats.
  [[nodiscard]] double gain_nats() const { return prior_entropy_nats - expected_entropy_nats; }
};

/// The terms of eq. (7) per hypothesis (for tests and inspection): k = 0..n-1 returns, n = none.
struct ExpectedEntropyTerms {
  std::vector<double> hypothesis_z_m;          ///< z_k, m (NaN for "no return" and for q_k = 0)
  std::vector<double> weight_unnormalised;     ///< q_k (or 1/eta_k in kPaperLiteral)
  std::vector<double> posterior_entropy_nats;  ///< H_k (0 where the weight is 0)
};

/// The geometry-only part of the fast evaluation of one ray: the hypotheses z_k, their weights'
/// forward-model terms (the Gaussian part of P(z in chord_k | r_i+) for the cells whose window
/// reaches chord_k), the cells each return leaves out, and a_j = p(z_k | r_j+) inside the window.
/// It depends on the chords and the sensor model, not on the priors, so rays with the same chords
/// (same direction, origin at the same place inside its cell) share it; a ray that leaves the map
/// earlier uses a prefix of it.
class RayKernel {
 public:
  /// Builds the kernel of a ray of n cells (chords and d_k as in ExpectedEntropy::Compute;
  /// cos_incidence as there, null for none).
  void Build(const SensorModel& model, const double* entry_m, const double* exit_m,
             const double* distance_m, int n, const double* cos_incidence = nullptr);
  /// Whether a ray of n cells is this kernel's ray or a prefix of it (chords within 1e-12 m, the
  /// same incidences).
  [[nodiscard]] bool Matches(const double* entry_m, const double* exit_m, const double* distance_m,
                             int n, const double* cos_incidence = nullptr) const;
  /// Cells of the ray it was built for.
  [[nodiscard]] int size() const { return n_; }

 private:
  friend class ExpectedEntropy;
  struct Hypothesis {
    int k{0};               // cell of the hypothetical return
    double z_m{0.0};        // z_k
    double uniform_q{0.0};  // p_rand u |chord_k cap [z_min, z_max)|
    int g_first{0};         // first cell i with a Gaussian term in q_k
    int g_count{0};
    size_t g_offset{0};
    int lo{0};   // cells before: a_j = p_rand u (non-decreasing over the hypotheses)
    int end{0};  // cells from here keep their prior
    size_t a_offset{0};
    double tail_a{0.0};  // a_j of the cells from `end` on and of the empty ray (eq. 4's tail)
  };
  int n_{-1};
  std::vector<double> entry_m_, exit_m_, distance_m_, cos_incidence_;
  std::vector<Hypothesis> hypotheses_;
  std::vector<double> g_, a_, no_return_;
  int near_cells_{0};  // cells with d < z_min
};

/// Caller-owned scratch for one thread: sized on first use, reused (no allocation per ray once
/// the largest ray has been seen).
class ExpectedEntropyScratch {
 public:
  ExpectedEntropyScratch() : isms_(1) {}

 private:
  friend class ExpectedEntropy;
  void Reserve(int n);
  InverseSensorModelScratch isms_;
  RayKernel kernel_;
  std::vector<double> posterior_, pi_, pbar_before_, pi_prefix_, suffix_h_, trunc_mass_, z_, q_,
      values_, counts_, eta_inv_;
  std::vector<double> in_lo_, in_hi_;
};

/// Expected entropy of one candidate ray (file comment). Pure functions of their arguments.
class ExpectedEntropy {
 public:
  /// E[H] and the prior entropy of the ray with chords [entry_m[j], exit_m[j]], distances
  /// d_j = distance_m[j] (non-decreasing) and priors prior[j] in [0, 1], j < n.
  /// @param terms optional: filled with the per-hypothesis terms (the direct method is used).
  /// @param cos_incidence optional, with a model whose direction_uncertainty_rad is above 0:
  ///   |cos| of the angle between the ray and the normal of the face through which it enters
  ///   cell j; a return in cell j is then predicted with the range band the mapper would give it
  ///   from such a plane (PredictedBandedReturn, docs/algorithms.md §3.8). Null: plain returns.
  /// @throws std::invalid_argument if n < 0 or a pointer is null while n > 0.
  static RayEntropy Compute(const SensorModel& model, const double* entry_m, const double* exit_m,
                            const double* distance_m, const double* prior, int n, WeightMode mode,
                            GainMethod method, ExpectedEntropyScratch* scratch,
                            ExpectedEntropyTerms* terms = nullptr,
                            const double* cos_incidence = nullptr);

  /// The fast evaluation with a prebuilt kernel, for the first n cells of its ray with priors
  /// prior[0..n); `sum` chooses how the entropies of the posteriors are summed (EntropySum).
  /// @throws std::invalid_argument if n > kernel.size() or an input is null.
  static RayEntropy Evaluate(const SensorModel& model, const RayKernel& kernel, const double* prior,
                             int n, WeightMode mode, ExpectedEntropyScratch* scratch,
                             EntropySum sum = EntropySum::kScalar);

 private:
  static RayEntropy Direct(const SensorModel& model, const double* entry_m, const double* exit_m,
                           const double* distance_m, const double* prior, int n, WeightMode mode,
                           ExpectedEntropyScratch* scratch, ExpectedEntropyTerms* terms,
                           const double* cos_incidence);
  static RayEntropy Fast(const SensorModel& model, const double* entry_m, const double* exit_m,
                         const double* distance_m, const double* prior, int n, WeightMode mode,
                         ExpectedEntropyScratch* scratch, const double* cos_incidence);
};

/// P(z in [a, b) | first occupied cell at distance d_m) under the forward model of section 3
/// with the model's Gaussian window (|z - d| <= c sigma), for [a, b) within [z_min, z_max).
[[nodiscard]] double ReturnIntervalProbability(const SensorModel& model, double d_m, double a_m,
                                               double b_m);

/// One sensor as seen by the planner: its forward model and horizontal field of view, centred on
/// the body x axis plus yaw_offset_rad. Rays start at the candidate position (the sensor's
/// lever arm, a few cm, is neglected in the 2D prediction) and are cast to z_max.
struct GainSensor {
  SensorModelConfig model;         ///< forward model (sigma, z_min, z_max, p_rand, p_miss, c)
  double horizontal_fov_rad{1.0};  ///< full horizontal field of view, rad, in (0, 2 pi]
  double yaw_offset_rad{0.0};      ///< sensor heading in the body, rad
  /// A planar scanner (the Hokuyo): it sees one layer, so with a layer map its rays are cast
  /// there instead of in E, whose columns it cannot see (GainEvaluator::HeadingGains).
  bool planar{false};
  double height_offset_m{0.0};  ///< sensor origin above the body origin, m (the layer's height)
};

/// Parameters of the gain of a candidate pose (eq. 10).
struct GainConfig {
  /// The sensors: the paper's Xtion (58 deg horizontal) and Hokuyo URG-04LX (240 deg).
  std::vector<GainSensor> sensors{
      GainSensor{SensorModelConfig::Xtion(), 58.0 * M_PI / 180.0, 0.0, false, 0.05},
      GainSensor{SensorModelConfig::Hokuyo(), 240.0 * M_PI / 180.0, 0.0, true, 0.12}};
  /// Ray directions are the multiples of 2 pi / rays_per_revolution inside each sensor's field
  /// of view (default 180: one ray per 2 degrees). All headings at one position share them.
  int rays_per_revolution{180};
  WeightMode weight_mode{WeightMode::kChordProbability};  ///< eq. (8) cleaned or literal
  GainMethod method{GainMethod::kFast};                   ///< fast or direct (equal to 1e-9)
  /// Fast method: keep one RayKernel per sensor and direction, reused by every position whose
  /// ray has the same chords (checked, rebuilt otherwise).
  bool cache_kernels{true};

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Counters of one gain evaluation.
struct GainStats {
  long rays_cast{0};      ///< distinct rays evaluated
  long ray_cells{0};      ///< sum of n_r over them
  long rays_per_pose{0};  ///< rays summed into one candidate's gain (all sensors)
  long kernels_built{0};  ///< RayKernels built (the other rays reused one)
};

/// Gains of candidate poses by 2D ray casting in a projected map (E or B), eq. (10).
/// Not thread-safe (owns scratch); one per thread.
class GainEvaluator {
 public:
  /// @throws std::invalid_argument if config.Validate() throws.
  explicit GainEvaluator(const GainConfig& config);

  /// I(X_c) for the headings yaw_m = yaw0_rad + 2 pi m / n_yaw, m = 0..n_yaw-1, at position_m
  /// (x, y, W) on `map`: for every heading, the sum of I_ray over every sensor's rays. Rays are
  /// evaluated once per position and direction and shared by the headings. nats.
  /// @throws std::invalid_argument if n_yaw < 1.
  /// With `excess` (two-map mode's end test), also each heading's gain minus the gain of the same
  /// pose on the saturated map (every cell P_sat = saturation_p where P <= 0.5, else 1 - P_sat):
  /// what can be learnt beyond the floor that E's P_min_E correction (eq. 15) keeps for ever. A
  /// ray whose cells are all saturated has excess 0 without a second evaluation.
  /// @throws std::invalid_argument if n_yaw < 1, or excess is set and saturation_p is not in
  /// (0, 0.5).
  /// With `planar_map` (same lattice as `map`), the rays of planar sensors are cast there.
  std::vector<double> HeadingGains(const GridMap2D& map, const Eigen::Vector2d& position_m,
                                   int n_yaw, double yaw0_rad = 0.0, GainStats* stats = nullptr,
                                   double saturation_p = 0.0, std::vector<double>* excess = nullptr,
                                   const GridMap2D* planar_map = nullptr);

  /// I(X_c) of one pose, nats (same rays as HeadingGains).
  double PoseGain(const GridMap2D& map, const Eigen::Vector2d& position_m, double yaw_rad);

  /// The ray indices m (direction 2 pi m / rays_per_revolution) of sensor s at heading yaw_rad.
  [[nodiscard]] std::vector<int> RayIndices(int sensor, double yaw_rad) const;

  /// I_ray of sensor s's ray from position_m along angle_rad in `map`, nats.
  double RayGain(const GridMap2D& map, int sensor, const Eigen::Vector2d& position_m,
                 double angle_rad);

  [[nodiscard]] const GainConfig& config() const { return config_; }
  /// Kernels built so far (cache misses), for benchmarks.
  [[nodiscard]] long kernels_built() const { return kernels_built_; }

 private:
  double EvaluateRay(const GridMap2D& map, int sensor, const Eigen::Vector2d& position_m,
                     double angle_rad, int kernel_slot, double saturation_p, double* excess);

  GainConfig config_;
  std::vector<SensorModel> models_;
  Ray2D ray_;
  std::vector<double> prior_;
  ExpectedEntropyScratch scratch_;
  std::vector<double> cache_;         // per sensor x direction, NaN when not yet computed
  std::vector<RayKernel> kernels_;    // per sensor x direction
  std::vector<double> excess_cache_;  // per sensor x direction, valid where cache_ is
  long kernels_built_{0};
};

}  // namespace kestrel
