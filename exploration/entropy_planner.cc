// The paper's planner, modes combined and two_map (exploration/entropy_planner.h).
#include "exploration/entropy_planner.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "common/check.h"

namespace kestrel {

EntropyPlanner::EntropyPlanner(const PlannerConfig& config)
    : config_(config),
      gains_(config.gain),
      space_(SearchSpace::Collision(config, config.mode == ExplorationMode::kTwoMap)) {
  config_.Validate();
  KESTREL_THROW_UNLESS(
      config_.mode == ExplorationMode::kCombined || config_.mode == ExplorationMode::kTwoMap,
      "EntropyPlanner: mode " << ModeName(config_.mode) << ", accepted combined or two_map");
}

bool EntropyPlanner::Reached(const PlannerInput& input, const GridMap2D& c, int cell,
                             double yaw_rad) const {
  if (!config_.candidates.skip_reached_goals) return false;
  const double half_step = M_PI / config_.candidates.n_yaw;
  for (const Eigen::Vector3d& g : input.reached_goals) {
    const std::optional<Cell2> gc = c.CellOf(g.head<2>());
    if (!gc || c.IndexOf(*gc) != cell) continue;
    const double d = std::remainder(g.z() - yaw_rad, 2.0 * M_PI);
    if (std::abs(d) < half_step) return true;
  }
  return false;
}

std::optional<GridMap2D> EntropyPlanner::PlanarLayer(const OccupancyGridView& map) const {
  for (const GainSensor& s : config_.gain.sensors) {
    if (!s.planar) continue;
    try {
      return ProjectLayer(map, config_.projection.height_m + s.height_offset_m);
    } catch (const std::invalid_argument&) {
      return std::nullopt;
    }
  }
  return std::nullopt;
}

Choice EntropyPlanner::ScoreCandidates(const PlannerInput& input, const GridMap2D& gain_map,
                                       bool two_map_end_test, PlanResult* result,
                                       const GridMap2D* planar_map) {
  const GridMap2D& c = result->collision.collision;
  const int n_yaw = config_.candidates.n_yaw;
  result->candidates.clear();
  result->end_test_gain_nats = 0.0;
  for (int cell : CandidateCells(result->field, config_.candidates)) {
    const Eigen::Vector2d p = c.CenterOf(c.CellAt(cell));
    std::vector<double> excess;
    const std::vector<double> gains = gains_.HeadingGains(
        gain_map, p, n_yaw, 0.0, &result->gain_stats, config_.projection.p_min_entropy,
        two_map_end_test ? &excess : nullptr, planar_map);
    for (int m = 0; m < n_yaw; ++m) {
      Candidate cand;
      cand.cell = cell;
      cand.position_m = p;
      cand.yaw_rad = 2.0 * M_PI * m / n_yaw;
      if (Reached(input, c, cell, cand.yaw_rad)) continue;
      cand.gain_nats = gains[static_cast<size_t>(m)];
      result->candidates.push_back(cand);
      if (two_map_end_test) {
        result->end_test_gain_nats =
            std::max(result->end_test_gain_nats, excess[static_cast<size_t>(m)]);
      }
    }
  }
  Choice choice = ChooseCandidate(result->field, config_.candidates, &result->candidates);
  if (input.current_goal && choice.index >= 0) {
    // Hysteresis (CandidateConfig::switch_margin): keep flying to the current goal unless the
    // best objective beats it by the margin.
    const double best = result->candidates[static_cast<size_t>(choice.index)].objective();
    const std::optional<Cell2> gc = c.CellOf(input.current_goal->head<2>());
    const double half_step = M_PI / n_yaw;
    for (size_t i = 0; gc && i < result->candidates.size(); ++i) {
      const Candidate& cand = result->candidates[i];
      if (cand.cell != c.IndexOf(*gc) ||
          std::abs(std::remainder(cand.yaw_rad - input.current_goal->z(), 2.0 * M_PI)) >=
              half_step) {
        continue;
      }
      if (cand.objective() > 0.0 &&
          best <= (1.0 + config_.candidates.switch_margin) * cand.objective()) {
        choice.index = static_cast<int>(i);
      }
      break;
    }
  }
  if (two_map_end_test) {
    // The end test on the gain beyond E's P_min_E floor (planner.h).
    choice.exploration_done = result->candidates.empty() ||
                              result->end_test_gain_nats < config_.candidates.end_entropy_gain_nats;
  }
  return choice;
}

PlanResult EntropyPlanner::Plan(const PlannerInput& input) { return RunPlan(input, space_, this); }

bool EntropyPlanner::CheckEntropyMap(const PlannerInput& input, const GridMap2D* planar_map,
                                     PlanResult* result, Choice* choice) {
  PlanResult on_e;
  on_e.collision = result->collision;
  on_e.field = result->field;
  try {
    on_e.entropy = ProjectEntropyMap(input.map, config_.projection);
  } catch (const std::invalid_argument& e) {
    result->reason = std::string("projection: ") + e.what();
    return false;
  }
  const Choice e_choice = ScoreCandidates(input, *on_e.entropy, true, &on_e, planar_map);
  if (!e_choice.exploration_done) {
    result->entropy = std::move(on_e.entropy);
    result->candidates = std::move(on_e.candidates);
    result->end_test_gain_nats = on_e.end_test_gain_nats;
    result->gain_stats = on_e.gain_stats;
    result->gains_from_entropy_map = true;
    *choice = e_choice;
  }
  return true;
}

GoalChoice EntropyPlanner::Choose(const PlannerInput& input, const SearchedCells&,
                                  PlanResult* result) {
  // Candidates: reachable lattice cells x headings; gains on B (combined) or E (two-map).
  const bool two_map = config_.mode == ExplorationMode::kTwoMap;
  // A planar scanner is credited against the layer it sees, not E's whole columns.
  const std::optional<GridMap2D> layer = PlanarLayer(input.map);
  Choice choice = ScoreCandidates(input, two_map ? *result->entropy : result->collision.combined,
                                  two_map, result, two_map && layer ? &*layer : nullptr);
  if (!two_map) {
    result->end_test_gain_nats = choice.best_unweighted_gain_nats;
    // B says explored; E may disagree (CandidateConfig::end_check_entropy_map).
    if (choice.exploration_done && config_.candidates.end_check_entropy_map &&
        !CheckEntropyMap(input, layer ? &*layer : nullptr, result, &choice)) {
      return {};
    }
  }
  result->volumetric_stats.positions =
      static_cast<long>(result->candidates.size()) / std::max(1, config_.candidates.n_yaw);
  result->best_unweighted_gain_nats = choice.best_unweighted_gain_nats;
  if (choice.exploration_done) {
    result->status = PlanStatus::kExplorationDone;
    result->reason = result->candidates.empty() ? "no reachable candidate"
                                                : "best unweighted gain below end_gain_nats";
    return {};
  }
  // The best candidate; if no trajectory reaches it, the next ones by objective (up to
  // GoalChoice::max_failures different cells).
  GoalChoice goals;
  goals.goals = GoalsByObjective(result->candidates, choice.index);
  return goals;
}

}  // namespace kestrel
