#pragma once
/// @file
/// The frontier baseline on the volumetric mode's fine traversability, search and trajectories
/// (frontier.fine_traversability; docs/exploration.md, "The frontier baseline"), on the planning
/// pipeline (exploration/planning_pipeline.h).

#include "exploration/planning_pipeline.h"

namespace kestrel {

/// The nearest (d_cell) reachable traversable cell from which, at some heading, the camera sees
/// at least frontier.min_frontier_cells frontier cells (exploration/frontiers.h: within the view's
/// ranges, inside its field of view, in sight over known free cells), facing the heading that
/// sees the most. Frontier cells that a reached goal saw (candidates.skip_reached_goals) are no
/// longer frontiers. The current goal is kept while it still sees enough; done ("no reachable
/// frontier") when no reachable cell does. Not thread-safe.
class FineFrontierPlanner final : public ExplorationPlanner, private Objective {
 public:
  /// @throws std::invalid_argument if config is invalid.
  explicit FineFrontierPlanner(const PlannerConfig& config);
  PlanResult Plan(const PlannerInput& input) override;
  [[nodiscard]] ExplorationMode mode() const override { return ExplorationMode::kFrontier; }

 private:
  GoalChoice Choose(const PlannerInput& input, const SearchedCells& cells,
                    PlanResult* result) override;

  PlannerConfig config_;
  VolumetricGainEvaluator gains_;  // the chosen frontier's 3D gain, for the status
  SearchSpace space_;
};

}  // namespace kestrel
