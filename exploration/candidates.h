#pragma once
/// @file
/// Candidate poses and the choice of the next one (docs/algorithms.md §8.3-§8.5, eqs. (9), (17)):
/// one reachable collision cell per block of the lattice (every `lattice_step` cells, anchored at
/// cell (0, 0): the lattice cell, or the block's reachable cell nearest to it)
/// times n_yaw headings yaw_m = 2 pi m / n_yaw; objective I(X_c) * bump(d_cell); the end of
/// exploration is decided on the best UNWEIGHTED gain max I(X_c).

#include <Eigen/Core>
#include <vector>

#include "exploration/dijkstra.h"
#include "exploration/grid_map_2d.h"

namespace kestrel {

/// How d_max of eq. (17) is chosen.
enum class DMaxPolicy {
  kSimulation,  ///< (1 + epsilon) * max d_cell (the paper's simulation)
  kExperiment,  ///< max(d_fixed, (1 + epsilon) * max d_cell) (the paper's experiment, 5 m)
};

/// Parameters of the candidate set and the objective.
struct CandidateConfig {
  int lattice_step{2};                               ///< lattice spacing in collision cells (>= 1)
  int n_yaw{8};                                      ///< headings per position (>= 1)
  DMaxPolicy d_max_policy{DMaxPolicy::kExperiment};  ///< eq. (17) d_max rule
  double d_max_epsilon{0.05};                        ///< epsilon of both policies (>= 0)
  double d_fixed_m{5.0};                             ///< d_fixed of kExperiment, m (> 0)
  double end_gain_nats{1.0};  ///< exploration ends when max I(X_c) < this, nats (>= 0)
  /// The end test on E (two-map mode; and combined mode's check, below): exploration ends when
  /// the best gain beyond E's P_min_E floor is below this, nats (>= 0). In a cluttered world it
  /// may never pass: 3D cells no sensor can see (inside walls and furniture) stay at P_init and
  /// keep some gain in their columns (as much as a half-seen corner; docs/STATUS.md), so
  /// the explorer's progress-stall test ends such flights (ExplorerConfig::end_stall_window_s).
  double end_entropy_gain_nats{1.0};
  /// Combined mode's end test (Kestrel's addition): B's min rule (eq. 16) calls a collision cell
  /// known once one of its band cells is seen free, so B can run out of gain with whole rooms
  /// unknown above and below the band (seen on lasr, docs/STATUS.md, "Exploration"). When true, a
  /// combined plan whose B test says "done" scores the candidates on E, and flies on with E's gains
  /// while they pass E's end test (end_entropy_gain_nats).
  bool end_check_entropy_map{true};
  /// Skip the vehicle's own collision cell, so that every plan moves the vehicle (a turn on the
  /// spot comes with the trajectory's yaw); the start-up scan has already looked around.
  bool exclude_vehicle_cell{true};
  /// Drop candidates the vehicle has already reached (same collision cell and heading; Kestrel's
  /// addition, not in the paper). A reached pose has looked at everything it can: what gain its
  /// prediction still shows lies in cells its sensors cannot see from there (inside furniture,
  /// under a table), and choosing it again makes the vehicle shuttle between such poses.
  bool skip_reached_goals{true};
  /// Hysteresis of replans on the way (Kestrel's addition): the goal being flown to is kept
  /// unless another candidate's objective exceeds its own by this fraction. The bump (eq. 17)
  /// favours candidates near the vehicle, so without it a replan halfway between two goals can
  /// swap them again and again and the vehicle never reaches either (seen on lasr). >= 0.
  double switch_margin{0.25};

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// One candidate pose with its gain and weight.
struct Candidate {
  int cell{-1};                                         ///< linear index in the collision map
  Eigen::Vector2d position_m{Eigen::Vector2d::Zero()};  ///< collision cell centre (x, y), m, W
  double yaw_rad{0.0};                                  ///< heading, rad
  double gain_nats{0.0};                                ///< I(X_c), eq. (10), nats
  double distance_m{0.0};                               ///< d_cell, m
  double bump{0.0};                                     ///< bump(d_cell), eq. (17)
  /// Several vehicles (docs/exploration.md, "Several vehicles"): the share of the gain left to
  /// this vehicle by the poses the others fly to, in [0, 1]; 1 with one vehicle.
  double discount{1.0};
  /// I(X_c) * bump(d_cell) (eq. (9)'s objective), times the discount.
  [[nodiscard]] double objective() const { return gain_nats * bump * discount; }
};

/// bump(d) = exp(1 - 1/(1 - (d/d_max)^2)) for |d| < d_max, else 0 (eq. 17). bump(0) = 1.
/// Precondition: d_max_m > 0.
[[nodiscard]] double Bump(double d_m, double d_max_m);

/// d_max of eq. (17) for the largest finite d_cell on the cost map (section 8). Never 0: with
/// max d_cell = 0 (only the start reachable) kSimulation gives a tiny positive value so that
/// bump(0) = 1.
[[nodiscard]] double DMax(const CandidateConfig& config, double max_distance_m);

/// One reachable cell per lattice block of the collision map: the block's corner (the lattice
/// cell) when reachable, else its reachable cell nearest to the corner (ties: lowest index), so
/// a one-cell corridor between lattice rows keeps candidates. Positions only (gains and headings
/// not filled), in increasing cell index; never field.start if config.exclude_vehicle_cell.
[[nodiscard]] std::vector<int> CandidateCells(const DistanceField& field,
                                              const CandidateConfig& config);

/// The choice among scored candidates.
struct Choice {
  int index{-1};                          ///< argmax of objective, -1 if there is no candidate
  double best_unweighted_gain_nats{0.0};  ///< max I(X_c) over all candidates
  bool exploration_done{false};           ///< best unweighted gain < end_gain_nats
};

/// Fills distance and bump of every candidate from `field` and picks argmax I * bump (ties: the
/// first). Exploration is done when there is no candidate or max I < end_gain_nats.
[[nodiscard]] Choice ChooseCandidate(const DistanceField& field, const CandidateConfig& config,
                                     std::vector<Candidate>* candidates);

}  // namespace kestrel
