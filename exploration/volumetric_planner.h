#pragma once
/// @file
/// The volumetric mode (docs/exploration.md, "Volumetric gain", "Traversability", "Choosing the
/// next pose"), on the planning pipeline (exploration/planning_pipeline.h) with the fine
/// traversability.

#include <unordered_map>
#include <vector>

#include "exploration/info_sites.h"
#include "exploration/planning_pipeline.h"

namespace kestrel {

/// The volumetric planner (docs/exploration.md): fine traversability (exploration/traversability.h)
/// and Dijkstra from the vehicle's cell; candidate positions every candidate_spacing_m on
/// reachable traversable cells x n_yaw headings; each pose's gain from the sensors' 3D rays
/// through the exact map (exploration/volumetric_gain.h, eqs. 7-10 per ray); objective gain x
/// bump(d_cell) (eqs. 9, 17); exploration ends when the best unweighted gain of every reachable
/// candidate is below volumetric.end_gain_nats.
///
/// Exact argmax with less work: a pose's gain is at most the prior entropy of the cells its rays
/// cross (E[H] >= 0), which costs a cast and a sum. Positions are evaluated exactly in decreasing
/// order of bound x bump until the best exact objective reaches the next bound x bump, so the
/// choice is the one evaluating every candidate gives; the end rule likewise evaluates in order of
/// bound until one exact gain passes the threshold or no bound can. Candidates listed in the
/// result are those evaluated exactly. Between replans a position keeps its gains while the map
/// within its rays' reach holds, and a memo per ray (RayMemo) otherwise: a ray that reads the
/// same priors again reuses its exact I_ray, which is also its bound. Not thread-safe.
class VolumetricPlanner final : public ExplorationPlanner, private Objective {
 public:
  /// @throws std::invalid_argument if config is invalid.
  explicit VolumetricPlanner(const PlannerConfig& config);
  PlanResult Plan(const PlannerInput& input) override;
  [[nodiscard]] ExplorationMode mode() const override { return config_.mode; }

  /// Positions whose gains were reused from an earlier replan in the last Plan (the map did not
  /// change within their rays' reach: exact reuse, same numbers).
  [[nodiscard]] int reused_positions() const { return reused_positions_; }

  /// Mode volumetric_tour, the last Plan: the information sites found and the order the tour
  /// visits them in (indices into sites; empty when the plan did not use the tour).
  [[nodiscard]] const std::vector<InfoSite>& tour_sites() const { return tour_sites_; }
  [[nodiscard]] const std::vector<int>& tour_order() const { return tour_order_; }

 private:
  struct Position;  // one candidate position and its gains
  struct Pass;      // one replan's positions and running figures
  // A position's bounds and (if evaluated) gains, valid while the map within its reach holds.
  struct CachedPose {
    std::vector<double> bounds;
    std::vector<double> gains;  // empty until evaluated exactly
    RayMemo memo;               // each ray's exact I_ray and the priors it was evaluated on
  };

  GoalChoice Choose(const PlannerInput& input, const SearchedCells& cells,
                    PlanResult* result) override;
  // The candidate positions: bounds (reused where the map held), the other vehicles' discount,
  // the headings looked from, cached exact gains.
  void Positions(Pass* pass);
  // The exact gains of a position (cached), the headings looked from set to 0.
  void Evaluate(Pass* pass, Position* p);
  // The exact argmax of gain x bump with the bump's d_max at bump_d_max among headings worth
  // min_goal_gain, in decreasing bound x bump; the best gain among positions with a positive
  // weight (local first asks it of the poses within the horizon).
  double ChooseByBound(Pass* pass, double bump_d_max, double min_goal_gain);
  // The end rule: does any reachable pose keep end_gain_nats? Evaluates in decreasing bound until
  // one does or no bound can.
  void EndRule(Pass* pass);
  // The evaluated poses into result->candidates; the best objective among gains worth
  // min_goal_gain (-1: none).
  int ListCandidates(Pass* pass, double min_goal_gain);
  // Hysteresis (candidates.switch_margin): the goal being flown to unless `chosen` beats it by the
  // margin (its pose evaluated, and listed, if the pruning skipped it).
  int KeepCurrentGoal(Pass* pass, int chosen, double min_goal_gain);
  // Compares the map with the copy of the last Plan in tiles of kTile x kTile columns and marks
  // the tiles within the rays' reach of a changed one (affected_); copies the map. All tiles are
  // affected when the lattice changed or on the first call.
  void UpdateAffectedTiles(const OccupancyGridView& map);
  // Mode volumetric_tour (docs/exploration.md, "The information tour"): the exact best gain of
  // every tile of tour_site_m (positions in decreasing bound until the tile's best exact gain
  // reaches the next bound; positions below end_gain_nats skipped), the sites, the travel-time
  // matrix and the open tour; the goal is a pose of the tour's first site (the current goal while
  // it lies there and keeps end_gain_nats). Returns its index in result->candidates after
  // ListCandidates (called here), or -1 when there is no site.
  int ChooseByTour(Pass* pass, const SearchedCells& cells);
  [[nodiscard]] bool Affected(const Cell2& cell) const;

  static constexpr int kTile = 8;
  PlannerConfig config_;
  VolumetricGainEvaluator gains_;
  SearchSpace space_;
  std::vector<float> previous_map_;
  Eigen::Vector3i previous_dims_{Eigen::Vector3i::Zero()};
  Eigen::Vector3d previous_origin_m_{Eigen::Vector3d::Zero()};
  double previous_resolution_m_{0.0};
  int tiles_x_{0};
  std::vector<bool> affected_;                 // per tile
  std::unordered_map<int, CachedPose> cache_;  // by 2D cell index
  int reused_positions_{0};
  std::vector<InfoSite> tour_sites_;
  std::vector<int> tour_order_;
};

/// The height at which poses' gains are predicted: h, or h + 1 mm when a sensor's origin would lie
/// on a cell boundary (within 1e-6 m), where every ray's first crossing ties with its start and
/// has to be cast at each position instead of following a shared template, m.
[[nodiscard]] double VolumetricGainHeight(const PlannerConfig& config,
                                          const OccupancyGridView& map);

}  // namespace kestrel
