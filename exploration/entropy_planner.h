#pragma once
/// @file
/// The paper's planner (Kaufman et al. 2018; docs/algorithms.md §7-§9), modes combined and
/// two_map, on the planning pipeline (exploration/planning_pipeline.h) with the collision map C.

#include <optional>

#include "exploration/planning_pipeline.h"

namespace kestrel {

/// The paper's planner: gains by eq. (10) on B (combined) or E (two-map), objective eq. (9)
/// weighted by eq. (17), end test on the unweighted gain. Not thread-safe.
///
/// Two-map end test: E's P_min_E correction (eq. 15) keeps every well-known cell at P_min_E or
/// 1 - P_min_E, whose entropy a measurement can still reduce, so a pose's E-gain never falls to
/// zero (about 1 nat per ray in open known space). In two-map mode the end test therefore uses,
/// per candidate, its gain minus the gain of the same pose on the saturated E (every cell at
/// P_min_E or 1 - P_min_E): exploration ends when the largest such excess is below
/// end_entropy_gain_nats.
class EntropyPlanner final : public ExplorationPlanner, private Objective {
 public:
  /// @throws std::invalid_argument if config is invalid or its mode is kFrontier.
  explicit EntropyPlanner(const PlannerConfig& config);
  PlanResult Plan(const PlannerInput& input) override;
  [[nodiscard]] ExplorationMode mode() const override { return config_.mode; }

 private:
  GoalChoice Choose(const PlannerInput& input, const SearchedCells& cells,
                    PlanResult* result) override;
  // Scores the candidates' gains on gain_map into result->candidates (without reached goals)
  // and chooses; with two_map_end_test, the end test on the excess over E's P_min_E floor.
  // With planar_map, planar sensors' rays are cast there (the layer they see).
  Choice ScoreCandidates(const PlannerInput& input, const GridMap2D& gain_map,
                         bool two_map_end_test, PlanResult* result,
                         const GridMap2D* planar_map = nullptr);
  // Combined mode, B's end test done: E's may disagree (CandidateConfig::end_check_entropy_map);
  // then the candidates and the choice come from E. False with result->reason if E cannot be
  // projected.
  bool CheckEntropyMap(const PlannerInput& input, const GridMap2D* planar_map, PlanResult* result,
                       Choice* choice);
  // The layer a planar sensor sees (ProjectLayer at h + its offset), if there is one inside the
  // map; nullopt otherwise (its rays then go through E, as in the paper).
  [[nodiscard]] std::optional<GridMap2D> PlanarLayer(const OccupancyGridView& map) const;
  // True if (cell, yaw) is a reached goal and candidates.skip_reached_goals is on.
  [[nodiscard]] bool Reached(const PlannerInput& input, const GridMap2D& c, int cell,
                             double yaw_rad) const;

  PlannerConfig config_;
  GainEvaluator gains_;
  SearchSpace space_;
};

}  // namespace kestrel
