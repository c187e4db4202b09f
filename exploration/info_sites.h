#pragma once
/// @file
/// Information sites and the travel times between them (docs/exploration.md, "The information
/// tour"): the candidate poses that still hold gain, grouped into square tiles of the 2D grid;
/// each tile with such a pose is a site, represented by its best pose (largest exact gain I). The
/// travel-time matrix between the vehicle (node 0) and the sites is FUEL's (Zhou et al. 2021)
/// leg cost t(i, j) = max(d_ij / v_max, |yaw_j - yaw_i| / yaw_rate_max), d_ij the Dijkstra path
/// length on the traversable cells (exploration/dijkstra.h, the same step weights), for the open
/// tour of exploration/tour.h.

#include <Eigen/Core>
#include <vector>

#include "exploration/dijkstra.h"
#include "exploration/grid_map_2d.h"
#include "exploration/tour.h"

namespace kestrel {

/// A candidate pose with its exact gain.
struct SitePose {
  int cell{-1};                                   ///< 2D cell index
  Eigen::Vector2d xy_m{Eigen::Vector2d::Zero()};  ///< cell centre, m, W
  double yaw_rad{0.0};                            ///< heading, rad
  double gain_nats{0.0};                          ///< I, nats
};

/// One site: a tile and its best pose.
struct InfoSite {
  int tile{-1};                 ///< tile index, tile_x + tiles_along_x * tile_y
  SitePose best;                ///< the tile's pose with the largest gain (ties: the first given)
  int poses{0};                 ///< the tile's poses worth min_gain_nats
  double total_gain_nats{0.0};  ///< the sum of those poses' gains (a figure for the status)
};

/// The sites of `poses` on tiles of tile_cells x tile_cells cells of `grid` (anchored at cell
/// (0, 0)), counting only poses with gain >= min_gain_nats; in increasing tile index.
/// @throws std::invalid_argument if tile_cells < 1.
[[nodiscard]] std::vector<InfoSite> GroupSites(const GridMap2D& grid,
                                               const std::vector<SitePose>& poses, int tile_cells,
                                               double min_gain_nats);

/// What the travel-time matrix is made of.
struct TravelTimeConfig {
  double speed_mps{1.0};       ///< v_max (> 0)
  double yaw_rate_radps{1.0};  ///< the yaw rate limit (> 0)
  /// Site-to-site distances on a grid coarser by this factor (>= 1; 1: exact Dijkstra on the
  /// given cells): a coarse cell is usable when any of its cells is, weighs the least of their
  /// step weights, and steps of coarsen cells; the vehicle's row stays exact.
  int coarsen{1};
};

/// The open-tour problem over the vehicle (node 0, at `vehicle_field`'s start with heading
/// vehicle_yaw_rad) and the sites (node k + 1 for sites[k]): c(0, k) from vehicle_field, c(i, j)
/// from a Dijkstra search from each site's best cell on `traversable` (width x height cells of
/// cell_m, with step_weight as in ComputeDistanceField); c(k, 0) = 0 (the tour is open). A site
/// the search does not reach costs 1e6 s (the tour then leaves it last).
/// @throws std::invalid_argument on an invalid config or inconsistent sizes.
[[nodiscard]] TourProblem TravelTimes(const DistanceField& vehicle_field, double vehicle_yaw_rad,
                                      const std::vector<InfoSite>& sites, int width, int height,
                                      const std::vector<bool>& traversable, double cell_m,
                                      const std::vector<double>& step_weight,
                                      const TravelTimeConfig& config);

}  // namespace kestrel
