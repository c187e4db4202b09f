#include "exploration/volumetric_gain.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <utility>

#include "common/check.h"
#include "mapping/occupancy_updater.h"

namespace kestrel {
namespace {

// Two positions share a template when their sensor origins' offsets inside their cells agree to
// this (rounding of positions built as cell centres is ~1e-15 m).
constexpr double kOffsetTolerance_m = 1e-10;

// One step of a RayMemo key: the value folded in, then a multiply-xorshift (MurmurHash3's
// 64-bit finaliser constants), so that every bit of every prior reaches every bit of the key.
inline uint64_t MixKey(uint64_t key, uint64_t value) {
  key = (key ^ value) * 0xff51afd7ed558ccdULL;
  return key ^ (key >> 33);
}
inline uint64_t KeyOf(float p) {
  uint32_t bits = 0;
  std::memcpy(&bits, &p, sizeof bits);
  return bits;
}
// The first step of a ray's key: its cell count and path (template or cast).
inline uint64_t SeedKey(int n, bool templated) {
  return MixKey(0x9e3779b97f4a7c15ULL, (static_cast<uint64_t>(n) << 1) | (templated ? 1u : 0u));
}
// The last step: MurmurHash3's fmix64; 0 is reserved for "no entry".
inline uint64_t FinishKey(uint64_t key) {
  key ^= key >> 33;
  key *= 0xc4ceb9fe1a85ec53ULL;
  key ^= key >> 33;
  return key == 0 ? 1 : key;
}
// Crossings closer than this (plus the offset tolerance's effect) make a ray fragile.
constexpr double kTieTolerance_m = 1e-9;
// Components below this are 0 (file comment of the header).
constexpr double kAxisSnap = 1e-15;

double Snap(double v) { return std::abs(v) < kAxisSnap ? 0.0 : v; }

// Chords from the midpoints (ray_caster.h): entry_0 = 0, exit_k = 2 d_k - entry_k.
void ChordsOf(const double* distance, int n, double* entry, double* exit) {
  double e = 0.0;
  for (int k = 0; k < n; ++k) {
    entry[k] = e;
    exit[k] = 2.0 * distance[k] - e;
    e = exit[k];
  }
}

// |cos| of the angle between the ray u and the normal of the face through which it enters each
// cell, for the predicted range bands (docs/algorithms.md §3.8, "Predicted bands"): the normal of
// the axis along which the cell's index changed from the previous cell's (the first cell, where
// the ray starts, enters through no face: 1). `axis_of(k)` is that axis, or -1 if none.
template <class AxisOf>
void IncidencesOf(const Eigen::Vector3d& u, int n, AxisOf&& axis_of, double* cos_incidence) {
  for (int k = 0; k < n; ++k) {
    const int a = k == 0 ? -1 : axis_of(k);
    cos_incidence[k] = a < 0 ? 1.0 : std::abs(u[a]);
  }
}

// Whether the DDA of direction u from o over length L has crossings that rounding at another
// origin with the same in-cell offset (within kOffsetTolerance_m) could order differently, or a
// crossing at 0 or at L: the cell list could differ from the template's.
bool IsFragile(const GridGeometry& g, const Eigen::Vector3d& o, const Eigen::Vector3d& u,
               double length) {
  std::vector<std::pair<double, double>> events;  // (t, half width)
  events.emplace_back(0.0, kTieTolerance_m);
  events.emplace_back(length, kTieTolerance_m);
  for (int a = 0; a < 3; ++a) {
    if (u[a] == 0.0) continue;
    const int step = u[a] > 0.0 ? 1 : -1;
    const double hw = kOffsetTolerance_m / std::abs(u[a]) + kTieTolerance_m;
    int64_t b = g.AxisIndexOf(a, o[a]) + (step > 0 ? 1 : 0);
    for (;;) {
      const double t = (g.Boundary(a, b) - o[a]) / u[a];
      if (t - hw > length) break;
      events.emplace_back(t, hw);
      b += step;
    }
  }
  std::sort(events.begin(), events.end());
  double right = -std::numeric_limits<double>::infinity();
  for (const auto& [t, hw] : events) {
    if (t - hw <= right) return true;
    right = std::max(right, t + hw);
  }
  return false;
}

}  // namespace

VolumetricSensor XtionVolumetricSensor() {
  VolumetricSensor s;
  s.name = "xtion";
  s.model = SensorModelConfig::Xtion();
  s.horizontal_fov_rad = 58.0 * M_PI / 180.0;
  s.vertical_fov_rad = 45.0 * M_PI / 180.0;
  s.rows = 5;
  s.height_offset_m = 0.05;
  s.reports_to_m = 8.0;
  return s;
}

VolumetricSensor HokuyoVolumetricSensor() {
  VolumetricSensor s;
  s.name = "hokuyo";
  s.model = SensorModelConfig::Hokuyo();
  s.horizontal_fov_rad = 240.0 * M_PI / 180.0;
  s.vertical_fov_rad = 0.0;
  s.rows = 1;
  s.height_offset_m = 0.12;
  return s;
}

void VolumetricGainConfig::Validate() const {
  KESTREL_THROW_UNLESS(!sensors.empty(),
                       "volumetric gain sensors: empty, accepted at least one sensor");
  KESTREL_THROW_UNLESS(opaque_probability > 0.5 - 1e-12 && opaque_probability <= 1.0,
                       "volumetric gain opaque_probability = " << opaque_probability
                                                               << ", accepted [0.5, 1] (1: off)");
  KESTREL_THROW_UNLESS(
      certain_probability >= 0.0 && certain_probability < 0.5,
      "volumetric gain certain_probability = " << certain_probability << ", accepted [0, 0.5)");
  for (size_t i = 0; i < sensors.size(); ++i) {
    const VolumetricSensor& s = sensors[i];
    s.model.Validate();
    KESTREL_THROW_UNLESS(s.horizontal_fov_rad > 0.0 && s.horizontal_fov_rad <= 2.0 * M_PI,
                         "volumetric gain sensors["
                             << i << "] (" << s.name << ").horizontal_fov_rad = "
                             << s.horizontal_fov_rad << ", accepted (0, 2 pi]");
    KESTREL_THROW_UNLESS(s.vertical_fov_rad >= 0.0 && s.vertical_fov_rad < M_PI,
                         "volumetric gain sensors[" << i << "] (" << s.name
                                                    << ").vertical_fov_rad = " << s.vertical_fov_rad
                                                    << ", accepted [0, pi) (0: planar)");
    KESTREL_THROW_UNLESS(s.rows >= 1 && s.rows <= 1000,
                         "volumetric gain sensors[" << i << "] (" << s.name << ").rows = " << s.rows
                                                    << ", accepted [1, 1000]");
    KESTREL_THROW_UNLESS(s.vertical_fov_rad > 0.0 || s.rows == 1,
                         "volumetric gain sensors[" << i << "] (" << s.name << ").rows = " << s.rows
                                                    << " with vertical_fov_rad = 0 (planar), "
                                                       "accepted 1");
    KESTREL_THROW_UNLESS(std::isfinite(s.yaw_offset_rad),
                         "volumetric gain sensors[" << i << "] (" << s.name << ").yaw_offset_rad = "
                                                    << s.yaw_offset_rad << ", accepted finite");
    KESTREL_THROW_UNLESS(std::isfinite(s.height_offset_m),
                         "volumetric gain sensors[" << i << "] (" << s.name
                                                    << ").height_offset_m = " << s.height_offset_m
                                                    << ", accepted finite");
  }
  KESTREL_THROW_UNLESS(
      azimuth_bins >= 1 && azimuth_bins <= 36000,
      "volumetric gain azimuth_bins = " << azimuth_bins << ", accepted [1, 36000]");
  KESTREL_THROW_UNLESS(min_ray_bound_nats >= 0.0 && std::isfinite(min_ray_bound_nats),
                       "volumetric gain min_ray_bound_nats = " << min_ray_bound_nats
                                                               << ", accepted [0, inf) (0: off)");
}

VolumetricGainEvaluator::VolumetricGainEvaluator(const VolumetricGainConfig& config)
    : config_(config) {
  config_.Validate();
  if (config_.certain_probability > 0.0) {
    certain_low_ = static_cast<float>(config_.certain_probability);
    certain_high_ = static_cast<float>(1.0 - config_.certain_probability);
  }
  if (config_.opaque_probability < 1.0) {
    certain_high_ = std::min(certain_high_, static_cast<float>(config_.opaque_probability));
  }
  int rows = 0;
  for (const VolumetricSensor& s : config_.sensors) {
    models_.emplace_back(s.model);
    SensorModelConfig reported = s.model;
    reported.no_return_informs = true;
    reported_models_.emplace_back(reported);
    row_base_.push_back(rows);
    rows += s.rows;
  }
  const size_t slots = static_cast<size_t>(rows) * static_cast<size_t>(config_.azimuth_bins);
  directions_.resize(slots);
  for (int s = 0; s < static_cast<int>(config_.sensors.size()); ++s) {
    for (int i = 0; i < config_.sensors[static_cast<size_t>(s)].rows; ++i) {
      for (int b = 0; b < config_.azimuth_bins; ++b) {
        directions_[static_cast<size_t>(Slot(s, i, b))] = Direction(s, i, b);
      }
    }
  }
  cast_kernels_.resize(slots);
  cast_distance_m_.resize(slots);
  cast_incidence_.resize(slots);
  templates_.resize(slots);
  const size_t bins = config_.sensors.size() * static_cast<size_t>(config_.azimuth_bins);
  bin_gain_.resize(bins);
  bin_bound_.resize(bins);
  bin_used_.resize(bins);
  for (int& k : entropy_key_) k = 0;  // bits of 0.0f, H(0) = 0
  for (double& h : entropy_value_) h = 0.0;
}

Eigen::Vector3d VolumetricGainEvaluator::Direction(int sensor, int row, int bin) const {
  const VolumetricSensor& s = config_.sensors[static_cast<size_t>(sensor)];
  const double az = 2.0 * M_PI * bin / config_.azimuth_bins;
  const double el = s.vertical_fov_rad == 0.0
                        ? 0.0
                        : -0.5 * s.vertical_fov_rad + s.vertical_fov_rad * (row + 0.5) / s.rows;
  return Eigen::Vector3d(Snap(std::cos(el) * std::cos(az)), Snap(std::cos(el) * std::sin(az)),
                         Snap(std::sin(el)));
}

std::vector<int> VolumetricGainEvaluator::BinsInView(int sensor, double yaw_rad) const {
  const VolumetricSensor& s = config_.sensors[static_cast<size_t>(sensor)];
  const int r = config_.azimuth_bins;
  const double step = 2.0 * M_PI / r;
  const double centre = yaw_rad + s.yaw_offset_rad;
  const long first =
      static_cast<long>(std::ceil((centre - 0.5 * s.horizontal_fov_rad) / step - 1e-9));
  long last = static_cast<long>(std::floor((centre + 0.5 * s.horizontal_fov_rad) / step + 1e-9));
  if (last - first + 1 > r) last = first + r - 1;  // a full circle: each bin once
  std::vector<int> out;
  for (long m = first; m <= last; ++m) out.push_back(static_cast<int>(((m % r) + r) % r));
  return out;
}

float VolumetricGainEvaluator::Certain(float p) const {
  if (p <= certain_low_) return 0.0f;
  if (p >= certain_high_) return 1.0f;
  return p;
}

double VolumetricGainEvaluator::CellEntropy(float p) {
  int32_t bits;
  std::memcpy(&bits, &p, sizeof(bits));
  const size_t slot = (static_cast<uint32_t>(bits) * 2654435761u) >> (32 - kEntropyBits);
  if (entropy_key_[slot] != bits) {
    entropy_key_[slot] = bits;
    entropy_value_[slot] = BinaryEntropy(p);
  }
  return entropy_value_[slot];
}

void VolumetricGainEvaluator::BuildTemplates(const std::vector<Eigen::Vector3d>& origins) {
  // An unbounded lattice aligned with the map: the templates reach z_max whatever the position.
  const GridGeometry lattice = GridGeometry::Unbounded(origin_m_, resolution_m_);
  const RayCaster caster(lattice);
  const int64_t nx = dims_.x(), nxy = static_cast<int64_t>(dims_.x()) * dims_.y();
  template_kernels_.clear();
  std::map<std::vector<int64_t>, std::vector<int>> by_chords;
  for (int s = 0; s < static_cast<int>(config_.sensors.size()); ++s) {
    const VolumetricSensor& sensor = config_.sensors[static_cast<size_t>(s)];
    const SensorModel& model = models_[static_cast<size_t>(s)];
    const double length = sensor.model.z_max_m;
    const Eigen::Vector3d& o = origins[static_cast<size_t>(s)];
    RayCells cells(length, resolution_m_);
    bool near_boundary = false;
    CellIndex c0;
    for (int a = 0; a < 3; ++a) {
      const int64_t i = lattice.AxisIndexOf(a, o[a]);
      c0[a] = static_cast<int32_t>(i);
      const double f = o[a] - lattice.Boundary(a, i);
      near_boundary = near_boundary || f < kOffsetTolerance_m + kTieTolerance_m ||
                      lattice.Boundary(a, i + 1) - o[a] < kOffsetTolerance_m + kTieTolerance_m;
    }
    for (int row = 0; row < sensor.rows; ++row) {
      for (int b = 0; b < config_.azimuth_bins; ++b) {
        const int slot = Slot(s, row, b);
        Template& t = templates_[static_cast<size_t>(slot)];
        const Eigen::Vector3d& u = directions_[static_cast<size_t>(slot)];
        t.delta.clear();
        t.offset.clear();
        // (Cell offsets are stored in 16 bits: rays of more than 30000 cells are cast instead.)
        t.fragile =
            near_boundary || length / resolution_m_ > 30000.0 || IsFragile(lattice, o, u, length);
        if (t.fragile) continue;
        const int n = caster.Cast(o, u, length, &cells);
        for (int a = 0; a < 3; ++a) t.lo[a] = t.hi[a] = 0;
        for (int k = 0; k < n; ++k) {
          const CellIndex& c = cells.cells[static_cast<size_t>(k)];
          const int32_t d[3] = {c.x - c0.x, c.y - c0.y, c.z - c0.z};
          t.delta.push_back(static_cast<int32_t>(d[0] + nx * d[1] + nxy * d[2]));
          for (int a = 0; a < 3; ++a) {
            t.offset.push_back(static_cast<int16_t>(d[a]));
            t.lo[a] = std::min<int16_t>(t.lo[a], static_cast<int16_t>(d[a]));
            t.hi[a] = std::max<int16_t>(t.hi[a], static_cast<int16_t>(d[a]));
          }
        }
        entry_.resize(static_cast<size_t>(n));
        exit_.resize(static_cast<size_t>(n));
        ChordsOf(cells.distance_m.data(), n, entry_.data(), exit_.data());
        const double* incidence = nullptr;
        if (model.config().direction_uncertainty_rad > 0.0) {
          incidence_.resize(static_cast<size_t>(n));
          IncidencesOf(
              u, n,
              [&cells](int k) {
                const CellIndex& before = cells.cells[static_cast<size_t>(k - 1)];
                const CellIndex& at = cells.cells[static_cast<size_t>(k)];
                return before.x != at.x ? 0 : before.y != at.y ? 1 : before.z != at.z ? 2 : -1;
              },
              incidence_.data());
          incidence = incidence_.data();
        }
        // Share the kernel of a ray with the same chords (to 1e-12 m) and the same model.
        std::vector<int64_t> key{s, n};
        for (int k = 0; k < n; ++k) {
          key.push_back(std::llround(cells.distance_m[static_cast<size_t>(k)] * 1e9));
        }
        std::vector<int>& same = by_chords[key];
        t.kernel = -1;
        for (int i : same) {
          const RayKernel& other = template_kernels_[static_cast<size_t>(i)];
          if (other.size() == n &&
              other.Matches(entry_.data(), exit_.data(), cells.distance_m.data(), n, incidence)) {
            t.kernel = i;
            break;
          }
        }
        if (t.kernel < 0) {
          t.kernel = static_cast<int>(template_kernels_.size());
          template_kernels_.emplace_back();
          template_kernels_.back().Build(model, entry_.data(), exit_.data(),
                                         cells.distance_m.data(), n, incidence);
          same.push_back(t.kernel);
        }
      }
    }
  }
  template_offset_m_.clear();
  for (const Eigen::Vector3d& o : origins) template_offset_m_.push_back(OffsetInCell(o));
  have_templates_ = true;
}

Eigen::Vector3d VolumetricGainEvaluator::OffsetInCell(const Eigen::Vector3d& o) const {
  Eigen::Vector3d f;
  for (int a = 0; a < 3; ++a) f[a] = o[a] - geometry_.Boundary(a, geometry_.AxisIndexOf(a, o[a]));
  return f;
}

bool VolumetricGainEvaluator::NoReturnReported(int sensor, int slot,
                                               const Eigen::Vector3d& o) const {
  const VolumetricSensor& s = config_.sensors[static_cast<size_t>(sensor)];
  if (s.reports_to_m <= 0.0 || s.model.no_return_informs) return false;
  const Eigen::Vector3d end = o + s.reports_to_m * directions_[static_cast<size_t>(slot)];
  const Eigen::Vector3d top = origin_m_ + resolution_m_ * dims_.cast<double>();
  return end.x() >= origin_m_.x() && end.x() <= top.x() && end.y() >= origin_m_.y() &&
         end.y() <= top.y() && end.z() <= top.z();
}

VolumetricGainEvaluator::RayResult VolumetricGainEvaluator::Finish(
    int sensor, int slot, const RayKernel& kernel, int n, double bound, uint64_t key, bool reported,
    bool with_gain, VolumetricGainStats* stats, RayMemo* memo) {
  RayResult r;
  // I_ray is the sum over the ray's cells of I(m_j; z), and for cells independent a priori that
  // sum is at most I(m; z) <= H(z) <= ln(number of hypotheses) <= ln(n + 1): for a ray through
  // unknown space (53 cells of 0.325 nats) this bound is 4 nats instead of 17. (Up to the snapping
  // of a return hypothesis to its chord's midpoint, information_gain.h; the bounds test checks
  // gain <= bound on random maps.)
  r.bound = config_.weight_mode == WeightMode::kChordProbability
                ? std::min(bound, std::log(static_cast<double>(n) + 1.0))
                : bound;
  if (stats != nullptr) {
    ++stats->rays;
    stats->ray_cells += n;
  }
  // A ray whose cells up to its first certain occupied cell are all certain (bound 0) has gain 0
  // exactly: every posterior equals its prior (0 or 1 stay, and pi vanishes behind P = 1).
  if (n == 0 || bound == 0.0 ||
      (config_.min_ray_bound_nats > 0.0 && bound < config_.min_ray_bound_nats)) {
    if (stats != nullptr) ++stats->rays_skipped;
    return r;
  }
  // The same priors as when this ray's I_ray was evaluated: the same I_ray, bit for bit (the
  // kernel and the sums depend on nothing else), and it is its own, exact, bound.
  if (memo != nullptr && memo->key[static_cast<size_t>(slot)] == key) {
    r.gain = memo->gain[static_cast<size_t>(slot)];
    r.bound = r.gain;
    if (stats != nullptr) ++stats->rays_memo_hits;
    return r;
  }
  if (!with_gain) return r;
  const RayEntropy e = ExpectedEntropy::Evaluate(
      (reported ? reported_models_ : models_)[static_cast<size_t>(sensor)], kernel, prior_.data(),
      n, config_.weight_mode, &scratch_, config_.entropy_sum);
  r.gain = e.gain_nats();
  if (stats != nullptr) ++stats->rays_evaluated;
  if (memo != nullptr) {
    memo->key[static_cast<size_t>(slot)] = key;
    memo->gain[static_cast<size_t>(slot)] = r.gain;
  }
  return r;
}

VolumetricGainEvaluator::RayResult VolumetricGainEvaluator::EvaluateRay(
    const OccupancyGridView& map, int sensor, int slot, const Eigen::Vector3d& o,
    const Eigen::Vector3i& cell, int64_t linear, bool use_template, bool with_gain,
    VolumetricGainStats* stats, RayMemo* memo) {
  const float* const p = map.probability;
  const Template& t = templates_[static_cast<size_t>(slot)];
  if (use_template && !t.fragile) {
    const int size = static_cast<int>(t.delta.size());
    int n = size;
    bool inside = true;
    for (int a = 0; a < 3; ++a) {
      inside = inside && cell[a] + t.lo[a] >= 0 && cell[a] + t.hi[a] < dims_[a];
    }
    if (!inside) {  // the in-bounds prefix: the first cell out of the map ends the ray
      const int16_t* off = t.offset.data();
      for (int k = 0; k < size; ++k, off += 3) {
        if (static_cast<unsigned>(cell[0] + off[0]) >= static_cast<unsigned>(dims_[0]) ||
            static_cast<unsigned>(cell[1] + off[1]) >= static_cast<unsigned>(dims_[1]) ||
            static_cast<unsigned>(cell[2] + off[2]) >= static_cast<unsigned>(dims_[2])) {
          n = k;
          break;
        }
      }
    }
    if (prior_.size() < static_cast<size_t>(n)) prior_.resize(2 * static_cast<size_t>(n) + 16);
    double bound = 0.0;
    bool visible = true;
    uint64_t key = SeedKey(n, true);
    const float* const base = p + linear;
    const int32_t* const delta = t.delta.data();
    for (int k = 0; k < n; ++k) {
      const float v = Certain(base[delta[k]]);
      prior_[static_cast<size_t>(k)] = static_cast<double>(v);
      if (memo != nullptr) key = MixKey(key, KeyOf(v));
      if (visible) {  // the bound stops at a certain occupied cell: nothing behind it counts
        bound += CellEntropy(v);
        visible = v != 1.0f;
      }
    }
    if (stats != nullptr) ++stats->templated_rays;
    const bool reported = NoReturnReported(sensor, slot, o);
    if (memo != nullptr) key = MixKey(key, reported ? 1u : 0u);
    return Finish(sensor, slot, template_kernels_[static_cast<size_t>(t.kernel)], n, bound,
                  FinishKey(key), reported, with_gain, stats, memo);
  }
  // Cast at this position (fragile ray, or an origin at another in-cell offset).
  const SensorModel& model = models_[static_cast<size_t>(sensor)];
  const RayCaster caster(geometry_);
  const int n = caster.CastWithLinearIndex(o, directions_[static_cast<size_t>(slot)],
                                           model.config().z_max_m, &cells_);
  if (prior_.size() < static_cast<size_t>(n)) prior_.resize(2 * static_cast<size_t>(n) + 16);
  double bound = 0.0;
  bool visible = true;
  uint64_t key = SeedKey(n, false);
  for (int k = 0; k < n; ++k) {
    const float v = Certain(p[cells_.linear_index[static_cast<size_t>(k)]]);
    prior_[static_cast<size_t>(k)] = static_cast<double>(v);
    if (memo != nullptr) key = MixKey(key, KeyOf(v));
    if (visible) {  // the bound stops at a certain occupied cell (see the gathering above)
      bound += CellEntropy(v);
      visible = v != 1.0f;
    }
  }
  RayKernel& kernel = cast_kernels_[static_cast<size_t>(slot)];
  const bool reported = NoReturnReported(sensor, slot, o);
  if (memo != nullptr) key = MixKey(key, reported ? 1u : 0u);
  key = FinishKey(key);
  if (!with_gain) {  // the kernel is not read
    return Finish(sensor, slot, kernel, n, bound, key, reported, false, stats, memo);
  }
  if (entry_.size() < static_cast<size_t>(n)) {
    entry_.resize(2 * static_cast<size_t>(n) + 16);
    exit_.resize(2 * static_cast<size_t>(n) + 16);
  }
  ChordsOf(cells_.distance_m.data(), n, entry_.data(), exit_.data());
  // Reused only for the very same chords (bit for bit): a ray cast elsewhere may differ by a
  // sliver chord where it grazes an edge (fragile rays), and kPaperLiteral weighs even a
  // sliver's hypothesis fully (1/eta_k is a density), so RayKernel::Matches's 1e-12 m and its
  // prefixes are not enough here.
  const double* incidence = nullptr;
  if (model.config().direction_uncertainty_rad > 0.0) {
    if (incidence_.size() < static_cast<size_t>(n)) incidence_.resize(2 * static_cast<size_t>(n));
    const int32_t* const li = cells_.linear_index.data();
    const int64_t nx = dims_.x(), nxy = static_cast<int64_t>(dims_.x()) * dims_.y();
    IncidencesOf(
        directions_[static_cast<size_t>(slot)], n,
        [li, nx, nxy](int k) {
          const int64_t step = std::abs(static_cast<int64_t>(li[k]) - li[k - 1]);
          return step == 1 ? 0 : step == nx ? 1 : step == nxy ? 2 : -1;
        },
        incidence_.data());
    incidence = incidence_.data();
  }
  std::vector<double>& built_for = cast_distance_m_[static_cast<size_t>(slot)];
  std::vector<double>& built_incidence = cast_incidence_[static_cast<size_t>(slot)];
  const double* const d = cells_.distance_m.data();
  if (kernel.size() != n || !std::equal(d, d + n, built_for.begin()) ||
      (incidence != nullptr && !std::equal(incidence, incidence + n, built_incidence.begin()))) {
    kernel.Build(model, entry_.data(), exit_.data(), d, n, incidence);
    built_for.assign(d, d + n);
    if (incidence != nullptr) built_incidence.assign(incidence, incidence + n);
  }
  return Finish(sensor, slot, kernel, n, bound, key, reported, true, stats, memo);
}

PoseGains VolumetricGainEvaluator::Evaluate(const OccupancyGridView& map,
                                            const Eigen::Vector3d& position_m, int n_yaw,
                                            bool with_gain, VolumetricGainStats* stats,
                                            RayMemo* memo) {
  KESTREL_THROW_UNLESS(n_yaw >= 1,
                       "VolumetricGainEvaluator: n_yaw = " << n_yaw << ", accepted >= 1");
  KESTREL_THROW_UNLESS(position_m.allFinite(), "VolumetricGainEvaluator: position not finite");
  map.Validate();
  if (stats != nullptr) ++(with_gain ? stats->poses_gained : stats->poses_bounded);
  KESTREL_THROW_UNLESS(
      static_cast<double>(map.dims.x()) * map.dims.y() * map.dims.z() < 2147483648.0,
      "VolumetricGainEvaluator: map of " << map.dims.transpose()
                                         << " cells, accepted < 2^31 cells");
  // The map's lattice (templates depend on it).
  if (!have_geometry_ || map.dims != dims_ || map.origin_m != origin_m_ ||
      map.resolution_m != resolution_m_) {
    dims_ = map.dims;
    origin_m_ = map.origin_m;
    resolution_m_ = map.resolution_m;
    MapLimits limits;
    limits.min_m = origin_m_;
    limits.resolution_m = resolution_m_;
    // (dims - 1/2) alpha: ceil gives dims whatever the rounding of the quotient.
    limits.max_m = origin_m_ + (dims_.cast<double>().array() - 0.5).matrix() * resolution_m_;
    geometry_ = GridGeometry::Fixed(limits);
    KESTREL_DEMAND(geometry_.upper().x == dims_.x() && geometry_.upper().y == dims_.y() &&
                   geometry_.upper().z == dims_.z());
    double longest = 0.0;
    for (const VolumetricSensor& s : config_.sensors) longest = std::max(longest, s.model.z_max_m);
    cells_ = RayCells(longest, resolution_m_);
    have_geometry_ = true;
    have_templates_ = false;
    ++generation_;
    have_miss_ = false;
  }
  const int n_sensors = static_cast<int>(config_.sensors.size());
  std::vector<Eigen::Vector3d> origins(static_cast<size_t>(n_sensors));
  for (int s = 0; s < n_sensors; ++s) {
    origins[static_cast<size_t>(s)] =
        position_m +
        Eigen::Vector3d(0.0, 0.0, config_.sensors[static_cast<size_t>(s)].height_offset_m);
  }
  // Templates: do this position's origins sit where the templates' did (inside their cells)?
  bool use_template = false;
  if (config_.use_templates) {
    const auto same = [&](const std::vector<Eigen::Vector3d>& offsets) {
      for (int s = 0; s < n_sensors; ++s) {
        const Eigen::Vector3d f = OffsetInCell(origins[static_cast<size_t>(s)]);
        if ((f - offsets[static_cast<size_t>(s)]).cwiseAbs().maxCoeff() > kOffsetTolerance_m) {
          return false;
        }
      }
      return true;
    };
    if (have_templates_ && same(template_offset_m_)) {
      use_template = true;
    } else if (have_miss_ && same(miss_offsets_m_)) {
      // A second position in a row at this offset: rebuild the templates for it.
      BuildTemplates(origins);
      ++generation_;
      if (stats != nullptr) {
        ++stats->templates_built;
        stats->template_kernels = static_cast<long>(template_kernels_.size());
      }
      use_template = true;
      have_miss_ = false;
    } else {
      miss_offsets_m_.clear();
      for (const Eigen::Vector3d& o : origins) miss_offsets_m_.push_back(OffsetInCell(o));
      have_miss_ = true;
    }
  }
  if (memo != nullptr && memo->generation != generation_) {
    memo->generation = generation_;
    memo->key.assign(directions_.size(), 0);
    memo->gain.assign(directions_.size(), 0.0);
  }
  // Which bins some heading uses.
  const int bins = config_.azimuth_bins;
  std::vector<std::vector<std::vector<int>>> view(static_cast<size_t>(n_sensors));
  std::fill(bin_used_.begin(), bin_used_.end(), 0);
  for (int s = 0; s < n_sensors; ++s) {
    view[static_cast<size_t>(s)].resize(static_cast<size_t>(n_yaw));
    for (int m = 0; m < n_yaw; ++m) {
      view[static_cast<size_t>(s)][static_cast<size_t>(m)] = BinsInView(s, 2.0 * M_PI * m / n_yaw);
      for (int b : view[static_cast<size_t>(s)][static_cast<size_t>(m)]) {
        bin_used_[static_cast<size_t>(s) * static_cast<size_t>(bins) + static_cast<size_t>(b)] = 1;
      }
    }
  }
  // Per-bin sums over the rows.
  std::fill(bin_gain_.begin(), bin_gain_.end(), 0.0);
  std::fill(bin_bound_.begin(), bin_bound_.end(), 0.0);
  for (int s = 0; s < n_sensors; ++s) {
    const Eigen::Vector3d& o = origins[static_cast<size_t>(s)];
    Eigen::Vector3i cell;
    bool inside = true;
    for (int a = 0; a < 3; ++a) {
      const int64_t i = geometry_.AxisIndexOf(a, o[a]);
      inside = inside && i >= 0 && i < dims_[a];
      cell[a] = static_cast<int>(std::clamp<int64_t>(i, 0, dims_[a] - 1));
    }
    const int rows = config_.sensors[static_cast<size_t>(s)].rows;
    if (!inside) {
      if (stats != nullptr) {
        for (int b = 0; b < bins; ++b) {
          if (bin_used_[static_cast<size_t>(s) * static_cast<size_t>(bins) +
                        static_cast<size_t>(b)] != 0) {
            stats->rays += rows;
            stats->rays_skipped += rows;
          }
        }
      }
      continue;  // no cells: gain and bound 0
    }
    const int64_t linear = cell.x() + static_cast<int64_t>(dims_.x()) *
                                          (cell.y() + static_cast<int64_t>(dims_.y()) * cell.z());
    for (int b = 0; b < bins; ++b) {
      const size_t at = static_cast<size_t>(s) * static_cast<size_t>(bins) + static_cast<size_t>(b);
      if (bin_used_[at] == 0) continue;
      double gain = 0.0, bound = 0.0;
      for (int row = 0; row < rows; ++row) {
        const RayResult r = EvaluateRay(map, s, Slot(s, row, b), o, cell, linear, use_template,
                                        with_gain, stats, memo);
        gain += r.gain;
        bound += r.bound;
      }
      bin_gain_[at] = gain;
      bin_bound_[at] = bound;
    }
  }
  // Heading windows: sums of the shared per-bin values.
  PoseGains out;
  out.bound_nats.assign(static_cast<size_t>(n_yaw), 0.0);
  if (with_gain) out.gain_nats.assign(static_cast<size_t>(n_yaw), 0.0);
  for (int m = 0; m < n_yaw; ++m) {
    for (int s = 0; s < n_sensors; ++s) {
      for (int b : view[static_cast<size_t>(s)][static_cast<size_t>(m)]) {
        const size_t at =
            static_cast<size_t>(s) * static_cast<size_t>(bins) + static_cast<size_t>(b);
        out.bound_nats[static_cast<size_t>(m)] += bin_bound_[at];
        if (with_gain) out.gain_nats[static_cast<size_t>(m)] += bin_gain_[at];
      }
    }
  }
  return out;
}

}  // namespace kestrel
