#pragma once
/// @file
/// Per-sensor forward model p(z | r_k+) (docs/algorithms.md §3.2): a Gaussian around the distance
/// d_k of the first occupied cell, truncated to [z_min, z_max) and renormalised, mixed with a
/// uniform spurious-return term, plus the discrete "no return" event.
///
/// With u = 1/(z_max - z_min) and G_k(z) = N(z; d_k, sigma^2) / (Phi((z_max-d_k)/sigma) -
/// Phi((z_min-d_k)/sigma)):
///   first occupied cell k in range (z_min <= d_k < z_max):
///     p(z | r_k+)    = p_rand * u + (1 - p_rand) * (1 - p_miss) * G_k(z)
///     P(none | r_k+) = (1 - p_rand) * p_miss
///   first occupied cell nearer than z_min, beyond z_max, or no occupied cell (k = n_r + 1):
///     p(z | r_k+)    = p_rand * u
///     P(none | r_k+) = 1 - p_rand
/// Gaussian window (Kestrel's choice, part of the model, docs/algorithms.md §3.3): the Gaussian
/// term is evaluated only for |z - d_k| <= cutoff_sigmas * sigma and taken as 0 beyond. With c >= 5
/// this drops at most 2*(1 - Phi(5)) = 5.7e-7 of the Gaussian's mass; c = +inf gives the
/// untruncated model of docs/algorithms.md §3.2. The same window makes a shortcut exact
/// (docs/algorithms.md §4.2: cells with d_k > z + c*sigma left out of a return's update): their
/// a_k is p_rand * u, the empty ray's, so their posteriors equal their priors.
///
/// Evaluation (switchable, SensorModelConfig::interpolated_gaussian, default on): the Gaussian
/// exp(-x^2/2) on [0, c] and 1/(truncation mass) on [z_min, z_max] come from cubic Hermite tables
/// with exact derivatives (steps 1/512 in x and sigma/256 in d), instead of one exp and two erfc
/// per cell. Their relative error in a_k is below 1e-10 (measured by
/// SensorModel.InterpolatedGaussianMatchesDirectEvaluation), far below the float storage of the
/// map (6e-8); the exactness oracle of section 4 uses the same a_k on both sides. Off, every a_k
/// is evaluated with exp and erfc.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace kestrel {

namespace kernels {
struct Kernels;  // one instruction set's kernels (kernels/kernels.h)
}  // namespace kernels

/// Parameters of one range sensor's forward model. Defaults: the paper's Xtion.
struct SensorModelConfig {
  double sigma_m{0.25};       ///< Gaussian standard deviation, m (paper: Xtion 0.25, Hokuyo 0.1)
  double z_min_m{0.5};        ///< shortest valid return, m (paper: 0.5)
  double z_max_m{4.0};        ///< longest return; rays are cast to here, m (paper: 4)
  double p_rand{0.1};         ///< probability of a spurious return, uniform on [z_min, z_max)
  double p_miss{0.05};        ///< probability that an in-range first occupied cell gives no return
  double cutoff_sigmas{5.0};  ///< Gaussian window c in sigmas (>= 5, or +inf for none)
  bool interpolated_gaussian{true};  ///< Hermite tables instead of exp/erfc (file comment)
  /// Whether the sensor's "nothing returned" reading is evidence (docs/algorithms.md §3.4). A
  /// depth camera's 0 is not: it also means "a surface nearer than the minimum", so with false a
  /// depth pixel of 0 is invalid (dropped and counted) and the explorer predicts no information
  /// from the no-return hypothesis. A range at or beyond z_max is a no-return either way.
  bool no_return_informs{true};
  /// How well the sensor's ray directions are known, rad (the mount's and the attitude's error
  /// together; docs/algorithms.md §3.8). Above 0, a return's range band (Reading::below_m)
  /// reaches down to the nearest range read within this angle of its ray (ScanIntegrator): the
  /// first surface along the believed ray may lie anywhere from there to z, so no cell in the
  /// band is freed by that return. 0 (the default): every ray's direction is taken as exact,
  /// and the map is the one without bands, bit for bit.
  double direction_uncertainty_rad{0.0};
  /// Widest range band that still says where the surface is, m (docs/algorithms.md §3.8): a
  /// return whose band is wider says only that nothing lies nearer than the band's near end
  /// (Reading::surface_unknown). +inf (the default): every band keeps its surface.
  double band_surface_max_m{std::numeric_limits<double>::infinity()};

  /// Kestrel's Asus Xtion (config/mapper.yaml; docs/algorithms.md §3.4, §3.6): sigma 0.1 m,
  /// 0.61..4 m along the ray (the device's 0.5 m minimum is axial: 0.61 m along a corner ray), a
  /// pixel of 0 no evidence (no_return_informs false).
  [[nodiscard]] static SensorModelConfig Xtion();
  /// Kestrel's Hokuyo URG-04LX: sigma 0.05 m over 0.5..4 m (the device ranges 0.02..5.6 m).
  [[nodiscard]] static SensorModelConfig Hokuyo();
  /// The paper's Xtion: sigma 0.25 m (inflated for pose error and distortion), 0.5..4 m.
  [[nodiscard]] static SensorModelConfig PaperXtion();
  /// The paper's Hokuyo: sigma 0.1 m, 0.5..4 m.
  [[nodiscard]] static SensorModelConfig PaperHokuyo();

  /// @throws std::invalid_argument naming the key, value and accepted range: sigma_m > 0,
  /// 0 <= z_min_m < z_max_m (finite), p_rand in (0, 1), p_miss in (0, 1), cutoff_sigmas >= 5,
  /// direction_uncertainty_rad in [0, 0.2].
  void Validate() const;
};

/// What a single range reading says.
enum class ReadingKind {
  kReturn,    ///< a return z in [z_min, z_max)
  kNoReturn,  ///< the discrete "no return" event (z >= z_max, +inf, Xtion pixel 0 by its caller)
  kInvalid,   ///< carries no information (NaN, negative, below z_min): dropped and counted
};

/// One reading along one ray.
struct Reading {
  ReadingKind kind{ReadingKind::kInvalid};  ///< what the reading says
  double z_m{0.0};                          ///< the range for kReturn, m; unused otherwise
  /// The range band of a return (docs/algorithms.md §3.8): the first surface along the believed
  /// ray may lie anywhere in [z - below_m, z], since the ray's true direction is known only to
  /// the sensor's direction_uncertainty_rad. 0: the plain model of section 3.
  double below_m{0.0};

  /// A band too wide to say where the surface is (SensorModelConfig::band_surface_max_m): the
  /// return says only that nothing lies nearer than z - below_m. Every hypothesis at or beyond
  /// that, "no surface" included, explains it equally well (docs/algorithms.md §3.8).
  bool surface_unknown{false};

  /// Whether the reading carries a band.
  [[nodiscard]] bool has_band() const { return below_m > 0.0 || surface_unknown; }
};

class SensorModel;

/// ReturnLikelihood of one SensorModel as a small value (the constants and table pointers
/// copied), so that a loop over a ray's cells keeps them in registers instead of reloading the
/// model's fields after every store. Same arithmetic, same values bit for bit. Valid while its
/// model lives.
class ReturnLikelihoodEvaluator {
 public:
  /// a_k = p(z | r_k+), 1/m (SensorModel::ReturnLikelihood).
  [[nodiscard]] double operator()(double z_m, double d_m) const {
    if (!(d_m >= z_min_m_ && d_m < z_max_m_)) return spurious_density_;
    const double r = std::abs(z_m - d_m);
    if (r > cutoff_m_) return spurious_density_;  // Gaussian window
    if (gaussian_table_ != nullptr) {
      // Section 3: p_rand u + (1 - p_rand)(1 - p_miss) G_k(z), from tables (file comment).
      return spurious_density_ +
             gaussian_scale_ * Hermite(gaussian_table_, gaussian_last_, r * gaussian_index_per_m_) *
                 Hermite(inv_mass_table_, mass_last_, (d_m - z_min_m_) * mass_index_per_m_);
    }
    return Direct(r, d_m);
  }

  /// a_k for a return z_m with a range band [lo_m, z_m] (docs/algorithms.md §3.8): the Gaussian
  /// of the distance from d to the band (0 inside it), its height scaled by `band_scale` =
  /// 1/(1 + (z - lo)/(sigma sqrt(2 pi))) so that it stays a density in z. With lo = z and
  /// band_scale = 1 the same value as operator()(z, d), bit for bit.
  [[nodiscard]] double Banded(double lo_m, double z_m, double band_scale, double d_m) const {
    if (!(d_m >= z_min_m_ && d_m < z_max_m_)) return spurious_density_;
    const double r = std::max(std::max(lo_m - d_m, d_m - z_m), 0.0);
    if (r > cutoff_m_) return spurious_density_;  // Gaussian window
    if (gaussian_table_ != nullptr) {
      return spurious_density_ +
             gaussian_scale_ * band_scale *
                 Hermite(gaussian_table_, gaussian_last_, r * gaussian_index_per_m_) *
                 Hermite(inv_mass_table_, mass_last_, (d_m - z_min_m_) * mass_index_per_m_);
    }
    return DirectBanded(r, d_m, band_scale);
  }

 private:
  friend class SensorModel;
  // Cubic Hermite interpolation at fractional index s >= 0 in a table of per-interval polynomial
  // coefficients (c0, c1, c2, c3): p(t) = c0 + t (c1 + t (c2 + t c3)), t = s - i. `last` is the
  // index of the last interval.
  static double Hermite(const double* table, int64_t last, double s) {
    // s >= 0: the signed conversion is one instruction (the unsigned one is a branchy sequence).
    int64_t i = static_cast<int64_t>(s);
    if (i > last) i = last;
    const double t = s - static_cast<double>(i);
    const double* c = table + 4 * i;
    return c[0] + t * (c[1] + t * (c[2] + t * c[3]));
  }
  // Section 3 evaluated with exp and erfc (tables off).
  double Direct(double r, double d_m) const;
  // The same with the Gaussian term's height times band_scale.
  double DirectBanded(double r, double d_m, double band_scale) const;

  const SensorModel* model_{nullptr};
  double z_min_m_{0.0};
  double z_max_m_{0.0};
  double cutoff_m_{0.0};
  double spurious_density_{0.0};
  double gaussian_scale_{0.0};
  const double* gaussian_table_{nullptr};  // null: direct evaluation
  const double* inv_mass_table_{nullptr};
  int64_t gaussian_last_{0};
  int64_t mass_last_{0};
  double gaussian_index_per_m_{0.0};
  double mass_index_per_m_{0.0};
};

/// The forward model with its constants precomputed. Immutable, cheap to copy.
class SensorModel {
 public:
  /// @throws std::invalid_argument if config.Validate() throws.
  explicit SensorModel(const SensorModelConfig& config);

  /// The configuration.
  [[nodiscard]] const SensorModelConfig& config() const { return config_; }

  /// Classifies a range (m): NaN or below z_min (negative included) -> kInvalid; >= z_max or
  /// +inf -> kNoReturn; otherwise kReturn. Sensors whose "no return" is encoded otherwise (Xtion
  /// pixel 0) map it before calling.
  [[nodiscard]] Reading Classify(double range_m) const;

  /// u = 1/(z_max - z_min), 1/m.
  [[nodiscard]] double uniform_density() const { return uniform_density_; }
  /// p(z | empty ray) = p(z | first occupied cell out of range) = p_rand * u, 1/m.
  [[nodiscard]] double spurious_density() const { return spurious_density_; }
  /// P(none | empty ray) = 1 - p_rand.
  [[nodiscard]] double empty_no_return_probability() const { return 1.0 - config_.p_rand; }
  /// Largest distance d_k at which a return z may still see the Gaussian: z + c*sigma, m.
  [[nodiscard]] double GaussianReach(double z_m) const { return z_m + cutoff_m_; }
  /// 1/(1 + w/(sigma sqrt(2 pi))) for a band of width w = below_m (1 without a band): the
  /// banded Gaussian's height relative to the plain one's (docs/algorithms.md §3.8).
  [[nodiscard]] double BandScale(const Reading& reading) const {
    if (!reading.has_band() || reading.surface_unknown) return 1.0;
    return 1.0 / (1.0 + reading.below_m * inv_sigma_sqrt_2pi_);
  }

  /// Whether a cell at distance d_m is certainly outside the Gaussian window of a return z_m on
  /// the near side (d < z_min, or z - d > c sigma): then ReturnLikelihood(z_m, d_m) is exactly
  /// spurious_density(). Cheap; used to find the leading cells of a ray that need no a_k.
  [[nodiscard]] bool SpuriousOnly(double z_m, double d_m) const {
    // | instead of ||: no branch (ExactUpdate::Forward's binary search over the cells).
    return static_cast<bool>(static_cast<int>(d_m < config_.z_min_m) |
                             static_cast<int>(z_m - d_m > cutoff_m_));
  }

  /// a_k = p(z | r_k+), 1/m, for a return z_m and first occupied cell at distance d_m (file
  /// comment; window included). Precondition: z_m in [z_min, z_max).
  [[nodiscard]] double ReturnLikelihood(double z_m, double d_m) const {
    return ReturnEvaluator()(z_m, d_m);
  }
  /// The same for a return with its range band (docs/algorithms.md §3.8; equal to
  /// ReturnLikelihood(z, d) without a band).
  [[nodiscard]] double ReturnLikelihood(const Reading& reading, double d_m) const {
    if (!reading.has_band()) return ReturnLikelihood(reading.z_m, d_m);
    const double lo = reading.z_m - reading.below_m;
    if (reading.surface_unknown && d_m >= lo) return EmptyRayLikelihood(reading);
    return ReturnEvaluator().Banded(lo, reading.z_m, BandScale(reading), d_m);
  }
  /// p(z | no occupied cell in the ray) for a return: p_rand u, or for a surface_unknown return
  /// the plateau's height at the band's near end (docs/algorithms.md §3.8).
  [[nodiscard]] double EmptyRayLikelihood(const Reading& reading) const {
    if (!reading.surface_unknown) return spurious_density_;
    const double lo = reading.z_m - reading.below_m;
    return ReturnEvaluator().Banded(lo, lo, 1.0, lo);
  }
  /// SpuriousOnly for a return with its range band: d < z_min, or z - below - d > c sigma.
  [[nodiscard]] bool SpuriousOnly(const Reading& reading, double d_m) const {
    return SpuriousOnly(reading.z_m - reading.below_m, d_m);
  }
  /// ReturnLikelihood as a value for inner loops (ReturnLikelihoodEvaluator).
  [[nodiscard]] ReturnLikelihoodEvaluator ReturnEvaluator() const {
    ReturnLikelihoodEvaluator e;
    e.model_ = this;
    e.z_min_m_ = config_.z_min_m;
    e.z_max_m_ = config_.z_max_m;
    e.cutoff_m_ = cutoff_m_;
    e.spurious_density_ = spurious_density_;
    e.gaussian_scale_ = gaussian_scale_;
    if (!gaussian_table_.empty()) {
      e.gaussian_table_ = gaussian_table_.data();
      e.inv_mass_table_ = inv_mass_table_.data();
    }
    e.gaussian_last_ = static_cast<int64_t>(gaussian_last_);
    e.mass_last_ = static_cast<int64_t>(mass_last_);
    e.gaussian_index_per_m_ = gaussian_index_per_m_;
    e.mass_index_per_m_ = mass_index_per_m_;
    return e;
  }
  /// Section 3's Gaussian term with exp and erfc, without the spurious term: (1 - p_rand)
  /// (1 - p_miss) G(z) for |z - d| = r_m (used when the tables are off).
  [[nodiscard]] double DirectGaussianTerm(double r_m, double d_m) const {
    return gaussian_scale_ * std::exp(-0.5 * r_m * r_m * inv_sigma2_) / TruncationMass(d_m);
  }

  /// a_k for eight rays at once, in RayBatch's layout (ray_caster.h): for lanes l < count and
  /// rows k < rows, likelihood[k * kLanes + l] = ReturnLikelihood(readings[l], d) for a
  /// return and NoReturnProbability(d) otherwise, d = distance_m[k * kLanes + l], bit for bit.
  /// Lanes at or beyond count and invalid readings get NoReturnProbability (values nobody
  /// reads). Only with the tables (interpolated_gaussian) and with kernels that have it
  /// (AVX-512), where it is faster than evaluating a_k cell by cell inside the update; returns
  /// whether it filled likelihood (otherwise the caller evaluates a_k itself). distance_m must
  /// be finite in rows < rows.
  bool FillLikelihoods(const Reading* readings, int count, const double* distance_m, int rows,
                       double* likelihood, const kernels::Kernels& kernels) const;

  /// P(none | r_k+) for the first occupied cell at distance d_m.
  [[nodiscard]] double NoReturnProbability(double d_m) const {
    return (d_m >= config_.z_min_m && d_m < config_.z_max_m) ? in_range_no_return_
                                                             : 1.0 - config_.p_rand;
  }

  /// Phi((z_max - d)/sigma) - Phi((z_min - d)/sigma): the Gaussian mass inside [z_min, z_max).
  [[nodiscard]] double TruncationMass(double d_m) const;

 private:
  // Appends the coefficients of the cubic Hermite interval between nodes (y0, slope m0) and
  // (y1, m1), slopes already multiplied by the step.
  static void AppendInterval(double y0, double m0, double y1, double m1,
                             std::vector<double>* table) {
    table->push_back(y0);
    table->push_back(m0);
    table->push_back(3.0 * (y1 - y0) - 2.0 * m0 - m1);
    table->push_back(2.0 * (y0 - y1) + m0 + m1);
  }

  SensorModelConfig config_;
  std::vector<double> gaussian_table_;  // exp(-x^2/2), x = r/sigma in [0, c]
  std::vector<double> inv_mass_table_;  // 1/TruncationMass(d), d in [z_min, z_max]
  double gaussian_index_per_m_{0.0};
  double mass_index_per_m_{0.0};
  size_t gaussian_last_{0};  // last interval of gaussian_table_
  size_t mass_last_{0};      // last interval of inv_mass_table_
  double uniform_density_;
  double spurious_density_;
  double gaussian_scale_;  // (1 - p_rand)(1 - p_miss) / (sigma sqrt(2 pi))
  double inv_sigma2_;
  double inv_sigma_sqrt2_;
  double inv_sigma_sqrt_2pi_;  // 1/(sigma sqrt(2 pi))
  double cutoff_m_;
  double in_range_no_return_;
};

}  // namespace kestrel
