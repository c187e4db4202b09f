#pragma once
/// @file
/// The explorer's messages from a replan (docs/design.md §2.1): the 2D maps as
/// kestrel::grid_map_t (MAP2D_*) and the decision as kestrel::exploration_status_t
/// (EXPLORATION_STATUS). Pure conversions, no LCM I/O.

#include <cstdint>
#include <string>

#include "exploration/explorer_state.h"
#include "exploration/grid_map_2d.h"
#include "exploration/occupancy_grid_view.h"
#include "exploration/planner.h"
#include "kestrel/exploration_status_t.hpp"
#include "kestrel/grid_map_t.hpp"

namespace kestrel {

/// A 2D map as a grid_map_t named `name` ("collision", "entropy", "combined"); values are the
/// map's probabilities as float, x fastest; stamped with seq and the publisher's epoch.
[[nodiscard]] grid_map_t ToGridMapMessage(const GridMap2D& map, const std::string& name,
                                          int64_t utime, int64_t seq, int64_t epoch);

/// What a status says besides the plan's result.
struct StatusContext {
  int64_t utime{0};  ///< stamp, us
  int64_t seq{0};    ///< the plan number
  int64_t epoch{0};  ///< the publisher's epoch
  ExplorationMode mode{ExplorationMode::kVolumetric};
  ExplorerState state{ExplorerState::kWaiting};  ///< the explorer's state after the decision
  std::string reason;                            ///< why the plan was made
  double map_entropy_nats{0.0};                  ///< H of the explorer's map (eq. 6), nats
  double height_m{0.0};                          ///< the exploration height h, m (the goals' z)
  int max_candidates{512};                       ///< candidates listed at most (best first)
};

/// The status of one plan: mode, state, reason ("<context reason>: <result reason>", or the
/// context's alone when the result gives none), map entropy, the best unweighted gain, the
/// candidates by decreasing objective (at most max_candidates) with the chosen one's index among
/// them (-1: none listed), the goal (x, y at height_m, yaw; zeros when none) and the stage times
/// (s).
[[nodiscard]] exploration_status_t ToStatusMessage(const PlanResult& result,
                                                   const StatusContext& context);

/// H(map), eq. (6): the sum of the binary entropies of every cell, nats.
[[nodiscard]] double MapEntropyNats(const OccupancyGridView& map);

}  // namespace kestrel
