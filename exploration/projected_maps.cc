#include "exploration/projected_maps.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/check.h"
#include "mapping/grid.h"
#include "mapping/occupancy_updater.h"

namespace kestrel {
namespace {
constexpr double kBandTolerance_m = 1e-9;
}  // namespace

void ProjectionConfig::Validate() const {
  KESTREL_THROW_UNLESS(std::isfinite(height_m),
                       "exploration height_m = " << height_m << ", accepted finite");
  KESTREL_THROW_UNLESS(
      collision_factor >= 0,
      "collision_factor = " << collision_factor << ", accepted >= 1, or 0 for the default");
  KESTREL_THROW_UNLESS(std::isfinite(vehicle_diameter_m) && vehicle_diameter_m > 0.0,
                       "vehicle_diameter_m = " << vehicle_diameter_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(collision_threshold >= 0.0 && collision_threshold < 1.0,
                       "collision_threshold = " << collision_threshold << ", accepted [0, 1)");
  KESTREL_THROW_UNLESS(std::isfinite(floor_height_m),
                       "floor_height_m = " << floor_height_m << ", accepted finite");
  KESTREL_THROW_UNLESS(ceiling_height_m > floor_height_m,
                       "ceiling_height_m = " << ceiling_height_m << ", accepted (floor_height_m = "
                                             << floor_height_m << ", inf]");
  KESTREL_THROW_UNLESS(p_min_entropy > 0.0 && p_min_entropy < 0.5,
                       "p_min_entropy = " << p_min_entropy << ", accepted (0, 0.5)");
  KESTREL_THROW_UNLESS(p_init > 0.0 && p_init < 1.0, "p_init = " << p_init << ", accepted (0, 1)");
  KESTREL_THROW_UNLESS(p_thresh > p_init && p_thresh < 1.0,
                       "p_thresh = " << p_thresh << ", accepted (p_init = " << p_init << ", 1)");
}

int CollisionFactor(const ProjectionConfig& config, double resolution_m) {
  if (config.collision_factor > 0) return config.collision_factor;
  // eq. (11): smallest k with k * alpha >= diameter (a tolerance absorbs 0.075 * 12 rounding).
  int k = static_cast<int>(std::ceil(config.vehicle_diameter_m / resolution_m - 1e-9));
  return std::max(k, 1);
}

double StartupFreeRadius(double collision_cell_m, double vertical_fov_rad) {
  KESTREL_THROW_UNLESS(vertical_fov_rad > 0.0 && vertical_fov_rad < M_PI,
                       "vertical_fov_rad = " << vertical_fov_rad << ", accepted (0, pi)");
  return 0.5 * collision_cell_m + collision_cell_m / (2.0 * std::tan(0.5 * vertical_fov_rad));
}

CollisionProjection ProjectCollisionMaps(const OccupancyGridView& map,
                                         const ProjectionConfig& config,
                                         const std::optional<StartupFreeZone>& startup) {
  map.Validate();
  config.Validate();
  const double alpha = map.resolution_m;
  const int kc = CollisionFactor(config, alpha);
  const double alpha_c = kc * alpha;  // eq. (11)
  const int width = (map.dims.x() + kc - 1) / kc;
  const int height = (map.dims.y() + kc - 1) / kc;
  CollisionProjection out;
  out.collision_factor = kc;
  const Eigen::Vector2d origin2 = map.origin_m.head<2>();
  out.collision = GridMap2D::Filled(origin2, alpha_c, config.height_m, width, height, 0.0);
  out.combined = out.collision;

  // Vertical band: cells whose [z, z + alpha) overlaps (h - alpha_C/2, h + alpha_C/2).
  const double band_lo = config.height_m - 0.5 * alpha_c;
  const double band_hi = config.height_m + 0.5 * alpha_c;
  int k_lo = std::numeric_limits<int>::max();
  int k_hi = -1;
  for (int k = 0; k < map.dims.z(); ++k) {
    const double z0 = map.origin_m.z() + k * alpha;
    const double z1 = map.origin_m.z() + (k + 1) * alpha;
    // Positive overlap, with a tolerance of kBandTolerance_m so that a cell only touching the
    // band at a boundary (up to rounding of h +- alpha_C/2) is not in it.
    if (z1 > band_lo + kBandTolerance_m && z0 < band_hi - kBandTolerance_m) {
      k_lo = std::min(k_lo, k);
      k_hi = std::max(k_hi, k);
    }
  }
  const double map_z_lo = map.origin_m.z();
  const double map_z_hi = map.origin_m.z() + map.dims.z() * alpha;
  const bool band_leaves_map =
      band_lo < map_z_lo - kBandTolerance_m || band_hi > map_z_hi + kBandTolerance_m;
  const float p_init_f = static_cast<float>(config.p_init);
  const double radius2 = startup ? startup->radius_m * startup->radius_m : -1.0;

  for (int cy = 0; cy < height; ++cy) {
    for (int cx = 0; cx < width; ++cx) {
      double p_max = -1.0;  // eq. (12)
      double p_min = 2.0;   // eq. (16), second case
      const bool sticks_out = (cx + 1) * kc > map.dims.x() || (cy + 1) * kc > map.dims.y();
      if (sticks_out || band_leaves_map || k_hi < 0) {
        p_max = config.p_init;  // missing cells are unknown (file comment)
        p_min = config.p_init;
      }
      const int i_end = std::min((cx + 1) * kc, map.dims.x());
      const int j_end = std::min((cy + 1) * kc, map.dims.y());
      for (int k = k_lo; k <= k_hi; ++k) {
        for (int j = cy * kc; j < j_end; ++j) {
          const double yc = map.origin_m.y() + (j + 0.5) * alpha;
          for (int i = cx * kc; i < i_end; ++i) {
            const float v =
                map.probability[static_cast<size_t>(i) +
                                static_cast<size_t>(map.dims.x()) *
                                    (static_cast<size_t>(j) +
                                     static_cast<size_t>(map.dims.y()) * static_cast<size_t>(k))];
            const double p = static_cast<double>(v);
            double p_collision = p;
            if (startup && v <= p_init_f) {
              // docs/algorithms.md §8.1: band cells near the start with no evidence of
              // occupancy (at or below P_init: unseen, or grazed by free rays) count as free in
              // C (and in B's maximum); B's minimum keeps what the map says.
              const double xc = map.origin_m.x() + (i + 0.5) * alpha;
              const double dx = xc - startup->center_m.x();
              const double dy = yc - startup->center_m.y();
              if (dx * dx + dy * dy <= radius2) p_collision = 0.0;
            }
            p_max = std::max(p_max, p_collision);
            p_min = std::min(p_min, p);
          }
        }
      }
      out.collision.at(cx, cy) = p_max;                                    // eq. (12)
      out.combined.at(cx, cy) = p_max >= config.p_thresh ? p_max : p_min;  // eq. (16)
    }
  }
  return out;
}

GridMap2D ProjectLayer(const OccupancyGridView& map, double z_m) {
  map.Validate();
  const int k = static_cast<int>(std::floor((z_m - map.origin_m.z()) / map.resolution_m));
  KESTREL_THROW_UNLESS(std::isfinite(z_m) && k >= 0 && k < map.dims.z(),
                       "layer height " << z_m << " m lies outside the map");
  GridMap2D g = GridMap2D::Filled(map.origin_m.head<2>(), map.resolution_m, z_m, map.dims.x(),
                                  map.dims.y(), 0.0);
  for (int j = 0; j < map.dims.y(); ++j) {
    for (int i = 0; i < map.dims.x(); ++i) g.at(i, j) = map.At(i, j, k);
  }
  return g;
}

GridMap2D ProjectEntropyMap(const OccupancyGridView& map, const ProjectionConfig& config) {
  map.Validate();
  config.Validate();
  const double alpha = map.resolution_m;
  int k_first = 0;  // first cell not wholly below the floor: top > floor
  while (k_first < map.dims.z() &&
         map.origin_m.z() + (k_first + 1) * alpha <= config.floor_height_m) {
    ++k_first;
  }
  int k_end = map.dims.z();  // one past the last cell not wholly above the ceiling
  while (k_end > k_first && map.origin_m.z() + (k_end - 1) * alpha >= config.ceiling_height_m) {
    --k_end;
  }
  KESTREL_THROW_UNLESS(k_first < k_end, "ProjectEntropyMap: no cell between floor_height_m = "
                                            << config.floor_height_m << " and ceiling_height_m = "
                                            << config.ceiling_height_m);
  GridMap2D e = GridMap2D::Filled(map.origin_m.head<2>(), alpha, config.height_m, map.dims.x(),
                                  map.dims.y(), 0.0);
  const double h_floor = BinaryEntropy(config.p_min_entropy);
  const int n_column = k_end - k_first;
  for (int j = 0; j < map.dims.y(); ++j) {
    for (int i = 0; i < map.dims.x(); ++i) {
      double best_p = map.At(i, j, k_first);
      double best_h = BinaryEntropy(best_p);
      double sum = 0.0;
      for (int k = k_first; k < k_end; ++k) {
        const double p = map.At(i, j, k);
        sum += p;
        const double h = BinaryEntropy(p);
        if (h > best_h) {  // eq. (14); ties keep the lowest cell
          best_h = h;
          best_p = p;
        }
      }
      if (best_h <= h_floor) {  // eq. (15)
        best_p = sum / n_column <= 0.5 ? config.p_min_entropy : 1.0 - config.p_min_entropy;
      }
      e.at(i, j) = best_p;
    }
  }
  return e;
}

}  // namespace kestrel
