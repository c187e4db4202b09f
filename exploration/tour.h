#pragma once
/// @file
/// Open asymmetric travelling-salesman paths (docs/exploration.md, "The information tour"): from a
/// fixed start node 0, an order of the other nodes that minimises the sum of the legs' costs
/// c(i, j), which need not equal c(j, i); the path ends at its last node (no return). Optionally
/// prize-collecting: node j has a prize p_j and the path may leave nodes out; it then minimises
/// w * (sum of its legs) - (sum of the prizes of the nodes it visits).
///
/// Two solvers: SolveTourExact, Held and Karp's dynamic programme over subsets (exact, O(2^n n^2),
/// n <= kMaxExactTourNodes), and SolveTourHeuristic: cheapest insertion and nearest neighbour,
/// each improved by 2-opt (a segment reversed, its legs costed in the direction then flown) and
/// Or-opt (a segment of 1-3 nodes moved, forwards or reversed) until no move improves (when
/// prize-collecting, also the best drop, add or swap of a node), then an iterated local search of
/// 20 n double-bridge kicks (and a node toggled, with prizes). SolveTour uses the exact one up to
/// kExactTourNodes. Deterministic: ties broken by index, the kicks from a fixed-seed generator.

#include <cstddef>
#include <vector>

namespace kestrel {

/// An open asymmetric TSP instance with start node 0.
struct TourProblem {
  int n{0};                   ///< nodes, the start (0) included; >= 1
  std::vector<double> cost;   ///< n * n, cost[i * n + j] = c(i, j) >= 0 and finite; diagonal unused
  std::vector<double> prize;  ///< empty: every node is visited; else n prizes p_j >= 0 (p_0 unused)
  double cost_weight{1.0};    ///< w of the prize-collecting objective (> 0)

  [[nodiscard]] double c(int i, int j) const {
    return cost[static_cast<size_t>(i) * static_cast<size_t>(n) + static_cast<size_t>(j)];
  }
  /// @throws std::invalid_argument naming what is wrong (sizes, negative or non-finite values).
  void Validate() const;
};

/// A path from node 0.
struct Tour {
  std::vector<int> order;  ///< node 0 first, then the visited nodes in order
  double cost{0.0};        ///< sum of c(order[k], order[k + 1])
  /// What the solvers minimise: `cost` when every node is visited; w * cost - (sum of the
  /// visited nodes' prizes) when prize-collecting.
  double objective{0.0};
};

/// Cost and objective of `order` (which must start with 0 and hold distinct nodes).
[[nodiscard]] Tour EvaluateTour(const TourProblem& problem, std::vector<int> order);

/// The exact solver's limit, nodes (the start included).
inline constexpr int kMaxExactTourNodes = 16;
/// SolveTour's switch to the heuristic, nodes (the start included).
inline constexpr int kExactTourNodes = 12;

/// Exact optimum (Held-Karp; ties: the first found in increasing subset and end-node order).
/// @throws std::invalid_argument if the problem is invalid or n > kMaxExactTourNodes.
[[nodiscard]] Tour SolveTourExact(const TourProblem& problem);

/// The heuristic (file comment); any n.
/// @throws std::invalid_argument if the problem is invalid.
[[nodiscard]] Tour SolveTourHeuristic(const TourProblem& problem);

/// SolveTourExact for n <= kExactTourNodes, else SolveTourHeuristic.
[[nodiscard]] Tour SolveTour(const TourProblem& problem);

}  // namespace kestrel
