// Open asymmetric TSP paths (exploration/tour.h; docs/exploration.md, "The information tour").
#include "exploration/tour.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>

namespace kestrel {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Whether `candidate` improves on `current` by more than rounding.
bool Better(double candidate, double current) {
  return candidate < current - 1e-9 * (1.0 + std::abs(current));
}

// A path under local search, with prefix sums of its legs in both directions so that every
// move's change of cost is O(1): fwd[k] = sum over t < k of c(p_t, p_t+1), bwd[k] likewise of
// c(p_t+1, p_t) (a segment flown backwards).
struct Path {
  std::vector<int> p;
  std::vector<double> fwd, bwd;
  double cost{0.0};

  void Update(const TourProblem& problem) {
    fwd.assign(p.size(), 0.0);
    bwd.assign(p.size(), 0.0);
    for (size_t k = 1; k < p.size(); ++k) {
      fwd[k] = fwd[k - 1] + problem.c(p[k - 1], p[k]);
      bwd[k] = bwd[k - 1] + problem.c(p[k], p[k - 1]);
    }
    cost = fwd.back();
  }
};

// 2-opt for an open asymmetric path: reverse p[i..j] (1 <= i < j), the reversed legs costed in
// the direction they are then flown. First improvement.
bool TwoOpt(const TourProblem& problem, Path* path) {
  const std::vector<int>& p = path->p;
  const size_t m = p.size();
  for (size_t i = 1; i + 1 < m; ++i) {
    for (size_t j = i + 1; j < m; ++j) {
      double delta = problem.c(p[i - 1], p[j]) - problem.c(p[i - 1], p[i]) +
                     (path->bwd[j] - path->bwd[i]) - (path->fwd[j] - path->fwd[i]);
      if (j + 1 < m) delta += problem.c(p[i], p[j + 1]) - problem.c(p[j], p[j + 1]);
      if (Better(path->cost + delta, path->cost)) {
        std::reverse(path->p.begin() + static_cast<std::ptrdiff_t>(i),
                     path->p.begin() + static_cast<std::ptrdiff_t>(j) + 1);
        path->Update(problem);
        return true;
      }
    }
  }
  return false;
}

// Or-opt: a segment p[i..e] of 1-3 nodes moved to after another node, as it is or reversed.
// First improvement.
bool OrOpt(const TourProblem& problem, Path* path) {
  const std::vector<int>& p = path->p;
  const size_t m = p.size();
  for (size_t length = 1; length <= 3; ++length) {
    for (size_t i = 1; i + length <= m; ++i) {
      const size_t e = i + length - 1;
      const int prev = p[i - 1];
      const bool has_next = e + 1 < m;
      double removal = -problem.c(prev, p[i]);
      if (has_next) removal += problem.c(prev, p[e + 1]) - problem.c(p[e], p[e + 1]);
      const double inner = path->fwd[e] - path->fwd[i];
      for (int reversed = 0; reversed < 2; ++reversed) {
        if (reversed == 1 && length == 1) break;
        const int first = reversed ? p[e] : p[i];
        const int last = reversed ? p[i] : p[e];
        const double inner_new = reversed ? path->bwd[e] - path->bwd[i] : inner;
        // After node p[k] of the path without the segment (k = i - 1: back where it was).
        for (size_t k = 0; k < m; ++k) {
          if (k >= i && k <= e) continue;
          if (k == i - 1 && reversed == 0) continue;  // the same path
          const int a = p[k];
          const size_t kb = k == i - 1 ? e + 1 : k + 1;  // a's successor without the segment
          double insertion = problem.c(a, first) + inner_new - inner;
          if (kb < m) insertion += problem.c(last, p[kb]) - problem.c(a, p[kb]);
          if (!Better(path->cost + removal + insertion, path->cost)) continue;
          std::vector<int> segment(p.begin() + static_cast<std::ptrdiff_t>(i),
                                   p.begin() + static_cast<std::ptrdiff_t>(e) + 1);
          if (reversed) std::reverse(segment.begin(), segment.end());
          std::vector<int> q;
          q.reserve(m);
          for (size_t t = 0; t < m; ++t) {
            if (t >= i && t <= e) continue;
            q.push_back(p[t]);
            if (t == k) q.insert(q.end(), segment.begin(), segment.end());
          }
          path->p = std::move(q);
          path->Update(problem);
          return true;
        }
      }
    }
  }
  return false;
}

// Prize-collecting moves: drop a visited node, add an unvisited one after some node, or swap a
// visited node for an unvisited one in its place. The best improvement of w * cost - prizes (a
// first improvement would drop the node just added and cycle between two paths).
bool DropAddOrSwap(const TourProblem& problem, Path* path) {
  const std::vector<int>& p = path->p;
  const size_t m = p.size();
  const double w = problem.cost_weight;
  auto prize = [&](int v) { return problem.prize[static_cast<size_t>(v)]; };
  std::vector<bool> in(static_cast<size_t>(problem.n), false);
  for (int v : p) in[static_cast<size_t>(v)] = true;
  double best = 0.0;
  int kind = -1;  // 0 drop, 1 add, 2 swap
  size_t at = 0;
  int node = -1;
  for (size_t i = 1; i < m; ++i) {
    const bool has_next = i + 1 < m;
    // Without p_i: the legs into and out of it replaced by one.
    double out = -problem.c(p[i - 1], p[i]);
    if (has_next) out += -problem.c(p[i], p[i + 1]);
    const double drop = w * (out + (has_next ? problem.c(p[i - 1], p[i + 1]) : 0.0)) + prize(p[i]);
    if (Better(drop, best)) {
      best = drop;
      kind = 0;
      at = i;
    }
    for (int v = 1; v < problem.n; ++v) {
      if (in[static_cast<size_t>(v)]) continue;
      double legs = problem.c(p[i - 1], v);
      if (has_next) legs += problem.c(v, p[i + 1]);
      const double swap = w * (out + legs) + prize(p[i]) - prize(v);
      if (Better(swap, best)) {
        best = swap;
        kind = 2;
        at = i;
        node = v;
      }
    }
  }
  for (int v = 1; v < problem.n; ++v) {
    if (in[static_cast<size_t>(v)]) continue;
    for (size_t k = 0; k < m; ++k) {
      double delta = problem.c(p[k], v);
      if (k + 1 < m) delta += problem.c(v, p[k + 1]) - problem.c(p[k], p[k + 1]);
      const double add = w * delta - prize(v);
      if (Better(add, best)) {
        best = add;
        kind = 1;
        at = k;
        node = v;
      }
    }
  }
  if (kind < 0) return false;
  if (kind == 0) path->p.erase(path->p.begin() + static_cast<std::ptrdiff_t>(at));
  if (kind == 1) path->p.insert(path->p.begin() + static_cast<std::ptrdiff_t>(at) + 1, node);
  if (kind == 2) path->p[at] = node;
  path->Update(problem);
  return true;
}

// Local search to a local optimum of every move.
Tour Improve(const TourProblem& problem, std::vector<int> order) {
  Path path;
  path.p = std::move(order);
  path.Update(problem);
  const bool prizes = !problem.prize.empty();
  while (TwoOpt(problem, &path) || OrOpt(problem, &path) ||
         (prizes && DropAddOrSwap(problem, &path))) {
  }
  return EvaluateTour(problem, std::move(path.p));
}

// Cheapest insertion over every node: the node and position that add the least cost, in turn.
std::vector<int> CheapestInsertion(const TourProblem& problem) {
  std::vector<int> order{0};
  std::vector<bool> in(static_cast<size_t>(problem.n), false);
  in[0] = true;
  for (int added = 1; added < problem.n; ++added) {
    double best = kInf;
    int best_node = -1;
    size_t best_k = 0;
    for (int v = 1; v < problem.n; ++v) {
      if (in[static_cast<size_t>(v)]) continue;
      for (size_t k = 1; k <= order.size(); ++k) {
        const int a = order[k - 1];
        const double delta =
            k == order.size() ? problem.c(a, v)
                              : problem.c(a, v) + problem.c(v, order[k]) - problem.c(a, order[k]);
        if (delta < best) {
          best = delta;
          best_node = v;
          best_k = k;
        }
      }
    }
    order.insert(order.begin() + static_cast<std::ptrdiff_t>(best_k), best_node);
    in[static_cast<size_t>(best_node)] = true;
  }
  return order;
}

// Nearest neighbour from node 0.
std::vector<int> NearestNeighbour(const TourProblem& problem) {
  std::vector<int> order{0};
  std::vector<bool> in(static_cast<size_t>(problem.n), false);
  in[0] = true;
  for (int added = 1; added < problem.n; ++added) {
    int best = -1;
    for (int v = 1; v < problem.n; ++v) {
      if (in[static_cast<size_t>(v)]) continue;
      if (best < 0 || problem.c(order.back(), v) < problem.c(order.back(), best)) best = v;
    }
    order.push_back(best);
    in[static_cast<size_t>(best)] = true;
  }
  return order;
}

}  // namespace

void TourProblem::Validate() const {
  if (n < 1) throw std::invalid_argument("tour: n = " + std::to_string(n) + ", need >= 1");
  if (cost.size() != static_cast<size_t>(n) * static_cast<size_t>(n)) {
    throw std::invalid_argument("tour: cost has " + std::to_string(cost.size()) +
                                " entries, need n * n = " + std::to_string(n * n));
  }
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const double v = c(i, j);
      if (i != j && (!std::isfinite(v) || v < 0.0)) {
        throw std::invalid_argument("tour: cost(" + std::to_string(i) + ", " + std::to_string(j) +
                                    ") = " + std::to_string(v) + ", need finite and >= 0");
      }
    }
  }
  if (!prize.empty()) {
    if (prize.size() != static_cast<size_t>(n)) {
      throw std::invalid_argument("tour: prize has " + std::to_string(prize.size()) +
                                  " entries, need 0 or n = " + std::to_string(n));
    }
    for (double p : prize) {
      if (!std::isfinite(p) || p < 0.0) {
        throw std::invalid_argument("tour: prize " + std::to_string(p) + ", need finite and >= 0");
      }
    }
    if (!std::isfinite(cost_weight) || cost_weight <= 0.0) {
      throw std::invalid_argument("tour: cost_weight = " + std::to_string(cost_weight) +
                                  ", need > 0");
    }
  }
}

Tour EvaluateTour(const TourProblem& problem, std::vector<int> order) {
  Tour t;
  for (size_t k = 1; k < order.size(); ++k) t.cost += problem.c(order[k - 1], order[k]);
  if (problem.prize.empty()) {
    t.objective = t.cost;
  } else {
    t.objective = problem.cost_weight * t.cost;
    for (size_t k = 1; k < order.size(); ++k) {
      t.objective -= problem.prize[static_cast<size_t>(order[k])];
    }
  }
  t.order = std::move(order);
  return t;
}

Tour SolveTourExact(const TourProblem& problem) {
  problem.Validate();
  const int n = problem.n;
  if (n > kMaxExactTourNodes) {
    throw std::invalid_argument("tour: exact solver for n <= " +
                                std::to_string(kMaxExactTourNodes) + ", got " + std::to_string(n));
  }
  if (n == 1) return EvaluateTour(problem, {0});
  // dp[S][j]: the least cost of a path from 0 over exactly the nodes of S (bit j - 1 for node j),
  // ending at j in S.
  const int m = n - 1;
  const size_t subsets = size_t{1} << m;
  std::vector<double> dp(subsets * static_cast<size_t>(m), kInf);
  std::vector<int> parent(subsets * static_cast<size_t>(m), -1);
  auto at = [m](size_t s, int j) { return s * static_cast<size_t>(m) + static_cast<size_t>(j); };
  for (int j = 0; j < m; ++j) dp[at(size_t{1} << j, j)] = problem.c(0, j + 1);
  for (size_t s = 1; s < subsets; ++s) {
    for (int j = 0; j < m; ++j) {
      if (!(s >> j & 1U)) continue;
      const double d = dp[at(s, j)];
      if (d == kInf) continue;
      for (int k = 0; k < m; ++k) {
        if (s >> k & 1U) continue;
        const size_t t = s | (size_t{1} << k);
        const double e = d + problem.c(j + 1, k + 1);
        if (e < dp[at(t, k)]) {
          dp[at(t, k)] = e;
          parent[at(t, k)] = j;
        }
      }
    }
  }
  // The best end: over the full set, or with prizes over every subset (the empty path too).
  const bool prizes = !problem.prize.empty();
  double best = prizes ? 0.0 : kInf;
  size_t best_s = 0;
  int best_j = -1;
  for (size_t s = prizes ? 1 : subsets - 1; s < subsets; ++s) {
    double collected = 0.0;
    if (prizes) {
      for (int j = 0; j < m; ++j) {
        if (s >> j & 1U) collected += problem.prize[static_cast<size_t>(j + 1)];
      }
    }
    for (int j = 0; j < m; ++j) {
      if (!(s >> j & 1U)) continue;
      const double o = prizes ? problem.cost_weight * dp[at(s, j)] - collected : dp[at(s, j)];
      if (o < best) {
        best = o;
        best_s = s;
        best_j = j;
      }
    }
  }
  std::vector<int> reversed;
  size_t s = best_s;
  for (int j = best_j; j >= 0;) {
    reversed.push_back(j + 1);
    const int p = parent[at(s, j)];
    s &= ~(size_t{1} << j);
    j = p;
  }
  std::vector<int> order{0};
  order.insert(order.end(), reversed.rbegin(), reversed.rend());
  return EvaluateTour(problem, std::move(order));
}

Tour SolveTourHeuristic(const TourProblem& problem) {
  problem.Validate();
  if (problem.n == 1) return EvaluateTour(problem, {0});
  Tour best = Improve(problem, CheapestInsertion(problem));
  Tour other = Improve(problem, NearestNeighbour(problem));
  if (Better(other.objective, best.objective)) best = std::move(other);
  if (!problem.prize.empty()) {  // also grown from the empty path by add moves
    Tour grown = Improve(problem, {0});
    if (Better(grown.objective, best.objective)) best = std::move(grown);
  }
  // Iterated local search: 20 n double bridges (the path after node 0 cut into A B C D and
  // rejoined A C B D, which 2-opt and Or-opt cannot undo in one move), each improved again; the
  // walk goes on from each kicked local optimum (a random walk over local optima, which leaves a
  // deep one more often than going back to the best), the best is kept. Cut points from a
  // fixed-seed generator, so the result is deterministic.
  std::mt19937 rng(12345U);
  const int kicks = 20 * problem.n;
  Tour current = best;
  const bool prizes = !problem.prize.empty();
  for (int k = 0; k < kicks; ++k) {
    std::vector<int> q = current.order;
    const size_t m = q.size() - 1;  // nodes after the start
    size_t cut[3];
    for (size_t& c : cut) c = 1 + static_cast<size_t>(rng() % std::max<size_t>(m, 1));
    std::sort(std::begin(cut), std::end(cut));
    const bool bridge = m >= 3 && cut[0] != cut[1] && cut[1] != cut[2];
    if (bridge) {
      const auto at = [&](size_t i) {
        return current.order.begin() + static_cast<std::ptrdiff_t>(i);
      };
      q.assign(current.order.begin(), at(cut[0]));
      q.insert(q.end(), at(cut[1]), at(cut[2]));
      q.insert(q.end(), at(cut[0]), at(cut[1]));
      q.insert(q.end(), at(cut[2]), current.order.end());
    }
    if (prizes) {
      // Prize-collecting: the kick also toggles one node (out of the path, or into it after its
      // cheapest predecessor), which the drop and add moves alone may not undo.
      const int v = 1 + static_cast<int>(rng() % static_cast<uint32_t>(problem.n - 1));
      const auto it = std::find(q.begin(), q.end(), v);
      if (it != q.end()) {
        q.erase(it);
      } else {
        size_t best_k = 0;
        for (size_t t = 1; t < q.size(); ++t) {
          if (problem.c(q[t], v) < problem.c(q[best_k], v)) best_k = t;
        }
        q.insert(q.begin() + static_cast<std::ptrdiff_t>(best_k) + 1, v);
      }
    } else if (!bridge) {
      continue;
    }
    current = Improve(problem, std::move(q));
    if (Better(current.objective, best.objective)) best = current;
  }
  return best;
}

Tour SolveTour(const TourProblem& problem) {
  return problem.n <= kExactTourNodes ? SolveTourExact(problem) : SolveTourHeuristic(problem);
}

}  // namespace kestrel
