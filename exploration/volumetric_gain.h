#pragma once
/// @file
/// Expected information gain of a candidate pose from the sensors' 3D measurement rays through
/// the 3D exact map (docs/exploration.md, section "Volumetric gain").
///
/// For a pose X_c = (position, yaw) the gain is eq. (10) summed over measurement rays:
///     I(X_c) = sum over sensors s, over the rays r of s inside its field of view at yaw,
///              of I_ray(r),   I_ray = sum_j H(P_j) - E[H]
/// where, for one ray, the cells j are those the 3D DDA (mapping/ray_caster.h) lists from the
/// sensor origin to z_max (or to where the ray leaves the map), P_j their priors in the map, and
/// E[H] the expected posterior entropy of eq. (7): hypotheses "return in chord k" (k = 1..n) and
/// "no return", posteriors by the mapper's exact inverse sensor model, weights by eq. (8)
/// (WeightMode::kChordProbability: the probability of the chord, or the paper's literal
/// 1/eta_k), as exploration/information_gain.h defines them (eqs. 7-10). Unlike the 2D gain in a
/// projected map, each ray reads the 3D cells it really crosses: a known wall hides what lies
/// behind it, and known free space contributes (almost) nothing.
///
/// Ray directions (the tests rebuild them with the same expressions): azimuth
/// az_b = 2 pi b / azimuth_bins, b = 0..azimuth_bins-1; elevation of row i of a sensor with
/// vertical FOV v and R rows el_i = -v/2 + v (i + 0.5) / R (0 for a planar scanner); direction
///     u = (cos(el) cos(az), cos(el) sin(az), sin(el)), each component of magnitude below 1e-15
///         replaced by 0 (axis-aligned rays stay exactly in a grid plane), not renormalised.
/// Sensor origin: position + (0, 0, height_offset_m). The horizontal lever arm of the real
/// sensors (a few cm forward in config/vehicle/paper.yaml) is neglected, so that the rays of one
/// position serve every heading.
/// Ray (s, i, b) is in sensor s's field of view at heading yaw when its azimuth lies within
/// [yaw + yaw_offset - hfov/2, yaw + yaw_offset + hfov/2] (1e-9 rad tolerance; a full circle
/// takes each bin once), the rule of GainEvaluator::RayIndices.
///
/// Speed (exact shortcuts, equal to the brute force to rounding, ~1e-12 relative at most):
///  - Each ray is cast once per position; per-bin sums (over rows) are shared by all headings.
///  - Ray templates: a ray's cell offsets from the origin cell and its chords depend only on its
///    direction and on the origin's offset inside its cell. For an origin offset (all of the
///    planner's candidates share one: cell centres in x, y and one height), every ray's cells are
///    stored once as linear-index deltas with per-axis offsets (for the bounds), together with its
///    RayKernel (information_gain.h). A position at the same offset (within 1e-10 m) gathers its
///    priors along the templates up to the map's bounds and calls ExpectedEntropy::Evaluate on the
///    in-bounds prefix. Rays whose DDA has a near-tie (two axis crossings within 1e-9 m plus the
///    offset tolerance's effect, a crossing at 0 or at z_max: e.g. diagonals through cell
///    corners), where rounding at another position may list a different cell, are cast per
///    position instead (as are all rays of a position at another in-cell offset), with a per-ray
///    RayKernel cache reused only for bit-identical chords. The templates are rebuilt when the map
///    geometry changes or when two consecutive positions share an offset other than theirs.
///    Rays whose chords agree to 1e-12 m (mirror images under the lattice's symmetries, from a
///    cell centre) share one RayKernel: 90 kernels for the default 720 rays.
///  - EntropySum::kLanes (entropy_sum): the posterior entropies and chord weights of eq. (7)-(8)
///    are summed eight cells at a time on AVX-512 (~1e-15 relative to the scalar sums).
/// Speed in the half-explored paper room (bench/exploration, BM_VolumetricGainPose and
/// BM_VolumetricBoundPose): docs/exploration.md, section "Volumetric gain".
///
/// Approximation (off by default; test VolumetricGain.ApproximationErrorIsMeasured measures it):
///  - min_ray_bound_nats > 0: a ray whose prior entropy sum_j H(P_j) is below it is not
///    evaluated and counts I_ray = 0 (error <= the threshold per ray wherever I_ray >= 0).
/// (Ending a ray after its first near-certain occupied cell is NOT offered: the return of that
/// cell spreads over c sigma beyond it, and dropping those chords renormalises the weights of
/// eq. 8: docs/exploration.md, "Volumetric gain", "Approximation".)

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "exploration/information_gain.h"
#include "exploration/projected_maps.h"
#include "mapping/grid.h"
#include "mapping/ray_caster.h"
#include "mapping/sensor_model.h"

namespace kestrel {

/// One sensor as the volumetric gain sees it.
struct VolumetricSensor {
  std::string name;  ///< for messages
  /// Forward model of eqs. (7)-(9) (sigma, z_min, z_max, p_rand, p_miss, c); rays are cast to
  /// model.z_max_m.
  SensorModelConfig model;
  double horizontal_fov_rad{1.0};  ///< full horizontal field of view, rad, in (0, 2 pi]
  /// Full vertical field of view, rad, in [0, pi); 0: a planar scanner (one row at elevation 0).
  double vertical_fov_rad{0.0};
  /// Elevation rows spread evenly over the vertical FOV, centres at -vfov/2 + vfov (i + 0.5)/rows;
  /// >= 1, and exactly 1 for a planar scanner.
  int rows{1};
  double yaw_offset_rad{0.0};  ///< sensor heading in the body, rad
  /// Sensor origin above the body origin, m (the horizontal lever arm is neglected: file comment).
  double height_offset_m{0.0};
  /// A sensor whose no-return is no evidence (model.no_return_informs false: the depth camera's
  /// 0) but which reports a reading beyond z_max up to this range, m (a real Xtion's depth to
  /// 8-10 m), which the mapper reads as a no-return, and which is evidence. The gain predicts the
  /// no-return hypothesis of such a ray as evidence when the ray's point at this range lies within
  /// the map's horizontal extent and not above its top: the map's box is taken as the building's
  /// envelope, so something within it answers the ray; a ray that leaves the box through a side
  /// or the top within this range may meet nothing (lasr has no ceiling) and reads 0, so it is
  /// predicted to teach nothing, as before (docs/exploration.md, "Volumetric gain"). 0: off
  /// (every no-return of the sensor predicted to teach nothing).
  double reports_to_m{0.0};
};

/// The paper's Asus Xtion: 58 x 45 deg, 5 rows, 0.05 m above the body origin, depth reported to
/// 8 m (reports_to_m).
[[nodiscard]] VolumetricSensor XtionVolumetricSensor();
/// The paper's Hokuyo URG-04LX: 240 deg planar scan, 0.12 m above the body origin.
[[nodiscard]] VolumetricSensor HokuyoVolumetricSensor();

/// Parameters of the volumetric gain (eq. 10 over 3D rays).
struct VolumetricGainConfig {
  /// Default: the paper's Xtion and Hokuyo (XtionVolumetricSensor, HokuyoVolumetricSensor).
  std::vector<VolumetricSensor> sensors{XtionVolumetricSensor(), HokuyoVolumetricSensor()};
  /// Ray azimuths 2 pi b / azimuth_bins, b = 0..bins-1, shared by all headings; [1, 36000].
  int azimuth_bins{60};
  WeightMode weight_mode{WeightMode::kChordProbability};  ///< eq. (8) cleaned or literal
  /// Ray templates (file comment); off: every ray of every position is cast (same numbers).
  bool use_templates{true};
  /// How the posterior entropies of eq. (7) are summed (EntropySum, information_gain.h): kLanes,
  /// eight cells at once on AVX-512, equal to kScalar to ~1e-15 relative (not bit for bit).
  EntropySum entropy_sum{EntropySum::kLanes};
  /// Approximation (file comment), 0 = off: rays with sum_j H(P_j) below this get I_ray = 0.
  double min_ray_bound_nats{0.0};
  /// The map's clamp P_min (config/mapper.yaml; 0 = off): a stored probability at or beyond it
  /// (P <= float(P_min) or P >= float(1 - P_min)) is read as certain, 0 or 1. The mapper never
  /// writes past its clamp, so such a cell cannot learn anything more, yet its entropy
  /// H(P_min) = 1e-3 nats over the ~50 cells of each of ~700 rays adds up to several nats of
  /// predicted gain on a fully explored map (docs/exploration.md, "Volumetric gain"): the
  /// floor that kept the paper's end rule from firing, in 3D.
  double certain_probability{1e-4};
  /// Visibility (docs/exploration.md, "Volumetric gain"; 1 = off): a stored probability at or
  /// above this is read as certain occupied (1), so the ray's cells behind it keep their priors
  /// under every hypothesis. Kestrel's sensor models spread a surface over several cells (sigma
  /// 0.25 m for the Xtion against 7.5 cm cells), so a wall seen a hundred times still stands at
  /// P = 0.6-0.97, and the exact model keeps predicting a glimpse of the unknown cells behind it
  /// that the real sensor never gets: a gain that no flight can collect, which kept the end rule
  /// from firing. Reading a more-likely-occupied-than-not surface as opaque is the one
  /// approximation of the volumetric gain; its effect is measured in
  /// tests/exploration/volumetric_gain_test.cc (OpaqueSurfaces).
  double opaque_probability{0.5};

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Counters of volumetric gain evaluations (accumulated by Evaluate).
struct VolumetricGainStats {
  long rays{0};              ///< rays cast or gathered (all bins x rows of every sensor used)
  long ray_cells{0};         ///< cells over those rays (in-bounds)
  long rays_evaluated{0};    ///< rays whose E[H] (eq. 7) was evaluated
  long rays_skipped{0};      ///< rays with no cell, or below min_ray_bound_nats
  long templated_rays{0};    ///< rays gathered along a template (the rest were cast per position)
  long templates_built{0};   ///< template sets built (each: every ray's cells and RayKernel)
  long template_kernels{0};  ///< distinct RayKernels in the last template set built
  long poses_bounded{0};     ///< positions evaluated for their bounds only
  long poses_gained{0};      ///< positions evaluated with their gains
  long rays_memo_hits{0};    ///< rays whose I_ray came from a RayMemo
  /// Candidate positions of the plan, set by the planner (the paper's modes: candidates / n_yaw;
  /// the fine frontier baseline: the cells it examined).
  long positions{0};
};

/// Per-heading results at one position, nats.
struct PoseGains {
  /// I(X_c) per heading (eq. 10 summed over the heading's rays), empty if only bounds were asked.
  std::vector<double> gain_nats;
  /// Upper bound per heading: the sum over its rays of min(sum_j H(P_j) over the cells up to the
  /// ray's first certain occupied cell, ln(n + 1)) (>= gain: E[H] >= 0, cells behind a certain
  /// occupied cell keep their prior under every hypothesis, and I_ray <= H(z) <= ln(n + 1)).
  std::vector<double> bound_nats;
};

/// The exact I_ray of each ray of one position, kept between evaluations (the caller owns one per
/// position): a ray whose cells read the same priors again (after Certain) reuses its I_ray
/// instead of evaluating eq. (7) anew, the same number bit for bit. Rays are recognised by a
/// 64-bit hash of their cell count, path (template or cast) and prior bits: reuse is exact unless
/// two different prior lists of one ray collide in 64 bits (about 2^-64 per comparison).
struct RayMemo {
  int64_t generation{-1};     ///< the evaluator's ray geometry it was filled under
  std::vector<uint64_t> key;  ///< per slot: hash of the priors I_ray was evaluated on (0: none)
  std::vector<double> gain;   ///< per slot: that I_ray, nats
};

/// Expected information gain of candidate poses from 3D rays through the exact map (file
/// comment). Not thread-safe (owns scratch and the templates); one per thread.
class VolumetricGainEvaluator {
 public:
  /// @throws std::invalid_argument if config.Validate() throws.
  explicit VolumetricGainEvaluator(const VolumetricGainConfig& config);

  /// Headings yaw_m = 2 pi m / n_yaw, m = 0..n_yaw-1, at the body origin position_m (x, y, z),
  /// W. A heading's gain is the sum over every sensor of I_ray over the sensor's rays whose
  /// azimuth lies inside its horizontal FOV centred on yaw_m + yaw_offset (file comment). Rays
  /// are cast once per position over 360 deg (the bins some heading uses x rows per sensor) and
  /// the per-bin sums are shared by the headings. with_gain = false: bounds only (cast and sum
  /// the prior entropy, no expected-entropy evaluation). A position whose sensor origins lie
  /// outside the map gets 0.
  /// @throws std::invalid_argument if n_yaw < 1 or the map view is invalid.
  ///
  /// memo (optional, one per position): rays whose priors are those of the memo's entry reuse
  /// its I_ray (the same bits as evaluating it), and their bound is that I_ray (an exact bound);
  /// rays evaluated with_gain are stored.
  PoseGains Evaluate(const OccupancyGridView& map, const Eigen::Vector3d& position_m, int n_yaw,
                     bool with_gain, VolumetricGainStats* stats = nullptr, RayMemo* memo = nullptr);

  /// The bins b of sensor s in its field of view at heading yaw_rad.
  [[nodiscard]] std::vector<int> BinsInView(int sensor, double yaw_rad) const;
  /// Unit direction of ray (row, bin) of sensor s (file comment), W.
  [[nodiscard]] Eigen::Vector3d Direction(int sensor, int row, int bin) const;

  [[nodiscard]] const VolumetricGainConfig& config() const { return config_; }

 private:
  // One ray of a template set: its cells relative to the origin cell and its kernel.
  struct Template {
    bool fragile{true};           // cast per position (near-tie in the DDA)
    std::vector<int32_t> delta;   // linear-index delta from the origin cell
    std::vector<int16_t> offset;  // di, dj, dk per cell (3 per cell)
    int16_t lo[3]{0, 0, 0};       // min of di, dj, dk over the ray
    int16_t hi[3]{0, 0, 0};       // max
    int kernel{-1};  // index in template_kernels_ (shared by rays with the same chords)
  };
  struct RayResult {
    double gain{0.0};
    double bound{0.0};
  };

  // Builds every ray's template for sensor origins `origins` (one per sensor).
  void BuildTemplates(const std::vector<Eigen::Vector3d>& origins);
  // Offset of o inside its cell of the map's lattice, m.
  [[nodiscard]] Eigen::Vector3d OffsetInCell(const Eigen::Vector3d& o) const;
  // H(p) of a stored probability, through a direct-mapped memo of exact values (maps hold few
  // distinct values: P_init, the clamps).
  double CellEntropy(float p);
  // A stored probability at the map's clamp as certain (VolumetricGainConfig::certain_probability).
  [[nodiscard]] float Certain(float p) const;
  // The ray of `slot` from origin o (cell `cell`, linear index `linear`), by template or cast.
  RayResult EvaluateRay(const OccupancyGridView& map, int sensor, int slot,
                        const Eigen::Vector3d& o, const Eigen::Vector3i& cell, int64_t linear,
                        bool use_template, bool with_gain, VolumetricGainStats* stats,
                        RayMemo* memo);
  // I_ray of the n cells in prior_ with `kernel` (read only when with_gain), and the bound;
  // `key` is the ray's memo key (RayMemo).
  // `reported`: the ray's no-return is evidence by VolumetricSensor::reports_to_m.
  RayResult Finish(int sensor, int slot, const RayKernel& kernel, int n, double bound, uint64_t key,
                   bool reported, bool with_gain, VolumetricGainStats* stats, RayMemo* memo);
  // Whether the ray of `slot` from o ends, at its sensor's reports_to_m, inside the map's
  // horizontal extent and not above its top (VolumetricSensor::reports_to_m).
  [[nodiscard]] bool NoReturnReported(int sensor, int slot, const Eigen::Vector3d& o) const;
  [[nodiscard]] int Slot(int sensor, int row, int bin) const {
    return (row_base_[static_cast<size_t>(sensor)] + row) * config_.azimuth_bins + bin;
  }

  VolumetricGainConfig config_;
  std::vector<SensorModel> models_;
  std::vector<SensorModel> reported_models_;  // per sensor: models_ with no_return_informs set
  std::vector<int> row_base_;                 // first row of each sensor in the slot numbering
  std::vector<Eigen::Vector3d> directions_;   // per slot

  // Geometry of the map the templates were built for, and their in-cell origin offsets.
  bool have_geometry_{false};
  Eigen::Vector3i dims_{Eigen::Vector3i::Zero()};
  Eigen::Vector3d origin_m_{Eigen::Vector3d::Zero()};
  double resolution_m_{0.0};
  GridGeometry geometry_;  // bounded lattice of the map (the per-position casts)
  bool have_templates_{false};
  int64_t generation_{0};  // bumped whenever the rays' cells or kernels may change (RayMemo)
  std::vector<Eigen::Vector3d> template_offset_m_;  // per sensor: origin offset inside its cell
  std::vector<Template> templates_;                 // per slot
  // Kernels of the templates: rays whose chords agree to 1e-12 m (mirror images of one another
  // under the lattice's symmetries, from a cell centre) share one.
  std::vector<RayKernel> template_kernels_;
  bool have_miss_{false};
  std::vector<Eigen::Vector3d> miss_offsets_m_;  // per sensor, of the last position that missed

  // Scratch.
  RayCells cells_{1.0, 1.0};
  std::vector<double> entry_, exit_, distance_, prior_;
  std::vector<double> incidence_;  // |cos| of each cell's entry face to the ray (bands only)
  ExpectedEntropyScratch scratch_;
  std::vector<RayKernel> cast_kernels_;               // per slot, for rays cast per position
  std::vector<std::vector<double>> cast_distance_m_;  // per slot: the d_k it was built for
  std::vector<std::vector<double>> cast_incidence_;   // per slot: its cos incidences (bands)
  std::vector<double> bin_gain_, bin_bound_;          // per sensor x bin
  std::vector<char> bin_used_;                        // per sensor x bin
  static constexpr int kEntropyBits = 12;
  float certain_low_{-1.0f};  // Certain(): P <= this reads 0 (off: below every probability)
  float certain_high_{2.0f};  // Certain(): P >= this reads 1 (the clamp or opaque_probability)
  int32_t entropy_key_[1 << kEntropyBits];  // float bits
  double entropy_value_[1 << kEntropyBits];
};

}  // namespace kestrel
