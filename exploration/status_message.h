#pragma once
/// @file
/// The explorer's messages from a replan (docs/design.md §2.1): the 2D maps as
/// kestrel::grid_map_t (MAP2D_*) and the decision as kestrel::exploration_status_t
/// (EXPLORATION_STATUS). Pure conversions, no LCM I/O.

#include <cstdint>
#include <string>

#include "exploration/grid_map_2d.h"
#include "exploration/planner.h"
#include "kestrel/exploration_status_t.hpp"
#include "kestrel/grid_map_t.hpp"

namespace kestrel {

/// A 2D map as a grid_map_t named `name` ("collision", "entropy", "combined"); values are the
/// map's probabilities as float, x fastest; stamped with seq and the publisher's epoch.
[[nodiscard]] grid_map_t ToGridMapMessage(const GridMap2D& map, const std::string& name,
                                          int64_t utime, int64_t seq, int64_t epoch);

/// The status of one replan: mode, state (exploration_status_t::STATE_*), reason, map entropy
/// (nats, from the mapper), the end-test gain (best_unweighted_gain_nats: the best unweighted
/// gain in combined and frontier mode, the gain beyond the P_min_E floor in two-map mode),
/// every candidate, the choice with its goal (x, y at height_m; NaN when none) and the stage
/// times (s); stamped with seq and the publisher's epoch.
[[nodiscard]] exploration_status_t ToStatusMessage(const PlanResult& result, ExplorationMode mode,
                                                   int8_t state, double map_entropy_nats,
                                                   double height_m, int64_t utime, int64_t seq,
                                                   int64_t epoch);

}  // namespace kestrel
