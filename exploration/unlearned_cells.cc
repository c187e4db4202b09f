#include "exploration/unlearned_cells.h"

#include <algorithm>
#include <cmath>
#include <queue>

#include "common/check.h"
#include "mapping/grid.h"
#include "mapping/occupancy_updater.h"
#include "mapping/ray_caster.h"

namespace kestrel {

namespace {

constexpr uint8_t kMarked = 255;  // streak_ value of an unlearned cell

// The fixed lattice of a view: (dims - 1/2) alpha above the origin, so that the rounding of the
// quotient cannot add a cell.
GridGeometry GeometryOf(const OccupancyGridView& map) {
  MapLimits limits;
  limits.min_m = map.origin_m;
  limits.resolution_m = map.resolution_m;
  limits.max_m = map.origin_m + (map.dims.cast<double>().array() - 0.5).matrix() * map.resolution_m;
  return GridGeometry::Fixed(limits);
}

double ValueAt(const OccupancyGridView& map, int32_t linear_index) {
  return static_cast<double>(map.probability[linear_index]);
}

}  // namespace

void UnlearnedCellsConfig::Validate() const {
  KESTREL_THROW_UNLESS(looks >= 2 && looks < kMarked,
                       "unlearned.looks = " << looks << ", accepted [2, 254]");
  KESTREL_THROW_UNLESS(
      std::isfinite(min_entropy_drop_nats) && min_entropy_drop_nats >= 0.0,
      "unlearned.min_entropy_drop_nats = " << min_entropy_drop_nats << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(
      certain_probability >= 0.0 && certain_probability < 0.5,
      "unlearned.certain_probability = " << certain_probability << ", accepted [0, 0.5)");
}

UnlearnedCells::UnlearnedCells(const UnlearnedCellsConfig& config) : config_(config) {
  config_.Validate();
}

void UnlearnedCells::Look(const OccupancyGridView& map, const std::vector<int32_t>& in_view) {
  map.Validate();
  if (map.dims != dims_ || map.origin_m != origin_m_ || map.resolution_m != resolution_m_) {
    dims_ = map.dims;
    origin_m_ = map.origin_m;
    resolution_m_ = map.resolution_m;
    const size_t n = static_cast<size_t>(dims_.prod());
    streak_.assign(n, 0);
    reference_h_.assign(n, 0.0F);
    last_look_.assign(n, 0);
    count_ = 0;
    looks_taken_ = 0;
  }
  ++looks_taken_;
  if (!config_.enabled) return;
  const uint32_t look = static_cast<uint32_t>(looks_taken_);
  // In the map's float: the clamp 1 - 1e-4 is stored as 0.9999f, below the double 1 - 1e-4.
  const float lo = static_cast<float>(config_.certain_probability);
  const float hi = static_cast<float>(1.0 - config_.certain_probability);
  for (const int32_t i : in_view) {
    if (i < 0 || static_cast<size_t>(i) >= streak_.size()) continue;
    if (last_look_[i] == look) continue;  // once per look
    last_look_[i] = look;
    uint8_t& streak = streak_[i];
    if (streak == kMarked) continue;  // for good
    const float stored = map.probability[i];
    // At the clamp the cell is certain for now: nothing to learn, nothing to chase, and no look
    // that counts either way. Its streak stays: a contested cell with a clamp that lets cells
    // come back (map.p_min 0.03) touches the clamp between swings, and resetting there would
    // never let it be marked.
    if (stored <= lo || stored >= hi) continue;
    const double h = BinaryEntropy(static_cast<double>(stored));
    // Nearly certain: less entropy left than a look has to remove to count as learning, so no
    // look could; like the clamp, neither counted nor ending the streak.
    if (h < config_.min_entropy_drop_nats) continue;
    if (streak == 0 || h < static_cast<double>(reference_h_[i]) - config_.min_entropy_drop_nats) {
      reference_h_[i] = static_cast<float>(h);  // a first look, or it learned: a new streak
      streak = 1;
      continue;
    }
    if (++streak >= config_.looks) {
      streak = kMarked;
      ++count_;
    }
  }
}

bool UnlearnedCells::unlearned(int32_t linear_index) const {
  return linear_index >= 0 && static_cast<size_t>(linear_index) < streak_.size() &&
         streak_[linear_index] == kMarked;
}

void UnlearnedCells::ApplyTo(std::vector<float>* probability, double certain_probability) const {
  if (count_ == 0) return;
  KESTREL_THROW_UNLESS(probability->size() == streak_.size(),
                       "UnlearnedCells::ApplyTo: " << probability->size()
                                                   << " cells, the ledger has " << streak_.size());
  const float low = static_cast<float>(certain_probability);
  const float high = static_cast<float>(1.0 - certain_probability);
  for (size_t i = 0; i < streak_.size(); ++i) {
    if (streak_[i] == kMarked) (*probability)[i] = (*probability)[i] <= 0.5F ? low : high;
  }
}

std::vector<UnlearnedRegion> UnlearnedCells::Regions(const OccupancyGridView& map,
                                                     size_t max_regions,
                                                     double* total_entropy_nats) const {
  std::vector<UnlearnedRegion> regions;
  if (total_entropy_nats != nullptr) *total_entropy_nats = 0.0;
  if (count_ == 0 || map.dims != dims_) return regions;
  const int nx = dims_.x(), ny = dims_.y(), nz = dims_.z();
  std::vector<uint8_t> seen(streak_.size(), 0);
  std::queue<int32_t> queue;
  for (size_t start = 0; start < streak_.size(); ++start) {
    if (streak_[start] != kMarked || seen[start] != 0) continue;
    UnlearnedRegion r;
    r.min_m = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    r.max_m = -r.min_m;
    double p_sum = 0.0;
    seen[start] = 1;
    queue.push(static_cast<int32_t>(start));
    while (!queue.empty()) {
      const int32_t i = queue.front();
      queue.pop();
      const int x = i % nx, y = (i / nx) % ny, z = i / (nx * ny);
      const Eigen::Vector3d lo = map.origin_m + Eigen::Vector3d(x, y, z) * map.resolution_m;
      r.min_m = r.min_m.cwiseMin(lo);
      r.max_m = r.max_m.cwiseMax(lo + Eigen::Vector3d::Constant(map.resolution_m));
      r.centroid_m += lo + Eigen::Vector3d::Constant(0.5 * map.resolution_m);
      const double p = ValueAt(map, i);
      p_sum += p;
      r.entropy_nats += BinaryEntropy(p);
      ++r.cells;
      for (int dz = -1; dz <= 1; ++dz) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const int a = x + dx, b = y + dy, c = z + dz;
            if (a < 0 || a >= nx || b < 0 || b >= ny || c < 0 || c >= nz) continue;
            const int32_t j = a + nx * (b + ny * c);
            if (streak_[j] == kMarked && seen[j] == 0) {
              seen[j] = 1;
              queue.push(j);
            }
          }
        }
      }
    }
    r.centroid_m /= static_cast<double>(r.cells);
    r.mean_probability = p_sum / static_cast<double>(r.cells);
    if (total_entropy_nats != nullptr) *total_entropy_nats += r.entropy_nats;
    regions.push_back(r);
  }
  std::stable_sort(
      regions.begin(), regions.end(),
      [](const UnlearnedRegion& a, const UnlearnedRegion& b) { return a.cells > b.cells; });
  if (regions.size() > max_regions) regions.resize(max_regions);
  return regions;
}

std::vector<int32_t> CellsInView(const OccupancyGridView& map,
                                 const std::vector<VolumetricSensor>& sensors,
                                 const Eigen::Vector3d& position_m, double yaw_rad,
                                 int azimuth_bins, int rows) {
  map.Validate();
  KESTREL_THROW_UNLESS(
      azimuth_bins >= 1 && rows >= 1,
      "CellsInView: azimuth_bins = " << azimuth_bins << ", rows = " << rows << ", accepted >= 1");
  const GridGeometry geometry = GeometryOf(map);
  const RayCaster caster(geometry);
  double longest = 0.0;
  for (const VolumetricSensor& s : sensors) longest = std::max(longest, s.model.z_max_m);
  RayCells cells(longest, map.resolution_m);
  std::vector<int32_t> out;
  const double step = 2.0 * M_PI / azimuth_bins;
  for (const VolumetricSensor& s : sensors) {
    const Eigen::Vector3d origin = position_m + Eigen::Vector3d(0, 0, s.height_offset_m);
    const int n_rows = s.vertical_fov_rad > 0.0 ? rows : 1;
    const double centre = yaw_rad + s.yaw_offset_rad;
    const int half = static_cast<int>(std::floor(0.5 * s.horizontal_fov_rad / step + 1e-9));
    for (int row = 0; row < n_rows; ++row) {
      const double el = s.vertical_fov_rad > 0.0
                            ? -0.5 * s.vertical_fov_rad + s.vertical_fov_rad * (row + 0.5) / n_rows
                            : 0.0;
      for (int b = -half; b <= half; ++b) {
        const double az = centre + b * step;
        const Eigen::Vector3d u(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                                std::sin(el));
        if (caster.CastWithLinearIndex(origin, u, s.model.z_max_m, &cells) <= 0) continue;
        for (int k = 0; k < cells.size; ++k) {
          if (cells.distance_m[k] < s.model.z_min_m) continue;  // the blind zone
          const int32_t i = cells.linear_index[k];
          out.push_back(i);
          if (ValueAt(map, i) > 0.5) break;  // behind it is not in view
        }
      }
    }
  }
  return out;
}

}  // namespace kestrel
