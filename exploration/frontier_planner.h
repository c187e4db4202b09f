#pragma once
/// @file
/// The frontier baseline on the paper's collision map C (frontier.fine_traversability false),
/// on the planning pipeline (exploration/planning_pipeline.h). The baseline on the fine
/// traversability is exploration/fine_frontier_planner.h.

#include "exploration/planning_pipeline.h"

namespace kestrel {

/// Yamauchi-style baseline: the nearest (by d_cell) reachable traversable collision cell, not
/// already reached (PlannerInput::reached_goals, with candidates.skip_reached_goals; the current
/// goal is kept while it is still a reachable frontier), with an
/// unknown 8-neighbour in C (not traversable and P_init/2 <= P(C) <= 0.5: not yet known free,
/// not known occupied, after docs/algorithms.md §12.2), facing the mean direction of its unknown
/// neighbours; done when no such cell is reachable. Its gain (on B, for the status) is computed
/// for the chosen pose only. Not thread-safe.
class FrontierPlanner final : public ExplorationPlanner, private Objective {
 public:
  /// @throws std::invalid_argument if config is invalid.
  explicit FrontierPlanner(const PlannerConfig& config);
  PlanResult Plan(const PlannerInput& input) override;
  [[nodiscard]] ExplorationMode mode() const override { return ExplorationMode::kFrontier; }

 private:
  GoalChoice Choose(const PlannerInput& input, const SearchedCells& cells,
                    PlanResult* result) override;

  PlannerConfig config_;
  GainEvaluator gains_;  // reports the chosen frontier's gain in nats for comparison
  SearchSpace space_;
};

}  // namespace kestrel
