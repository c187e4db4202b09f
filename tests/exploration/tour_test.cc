// Open asymmetric TSP paths (exploration/tour.h): the exact solver against enumeration, the
// heuristic against the exact optimum, on random asymmetric instances (seeded, deterministic).
#include "exploration/tour.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

namespace kestrel {
namespace {

// A random asymmetric instance: points in a 20 m square (a path's length) plus a random
// per-direction term (a turn's time), so c(i, j) != c(j, i) and the triangle inequality may fail.
TourProblem RandomProblem(int n, uint32_t seed, bool prizes) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> x(static_cast<size_t>(n)), y(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    x[static_cast<size_t>(i)] = 20.0 * u(rng);
    y[static_cast<size_t>(i)] = 20.0 * u(rng);
  }
  TourProblem p;
  p.n = n;
  p.cost.assign(static_cast<size_t>(n * n), 0.0);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      if (i == j) continue;
      const double d = std::hypot(x[static_cast<size_t>(i)] - x[static_cast<size_t>(j)],
                                  y[static_cast<size_t>(i)] - y[static_cast<size_t>(j)]);
      p.cost[static_cast<size_t>(i * n + j)] = d + 8.0 * u(rng);
    }
  }
  if (prizes) {
    p.prize.assign(static_cast<size_t>(n), 0.0);
    for (int i = 1; i < n; ++i) p.prize[static_cast<size_t>(i)] = 15.0 * u(rng);
    p.cost_weight = 0.5 + u(rng);
  }
  return p;
}

// Every order of every subset the problem allows (all nodes, or any subset with prizes).
double Enumerate(const TourProblem& p) {
  const int m = p.n - 1;
  double best = p.prize.empty() ? std::numeric_limits<double>::infinity() : 0.0;
  for (uint32_t s = p.prize.empty() ? (1U << m) - 1 : 1; s < (1U << m); ++s) {
    std::vector<int> nodes;
    for (int j = 0; j < m; ++j) {
      if (s >> j & 1U) nodes.push_back(j + 1);
    }
    do {
      std::vector<int> order{0};
      order.insert(order.end(), nodes.begin(), nodes.end());
      best = std::min(best, EvaluateTour(p, order).objective);
    } while (std::next_permutation(nodes.begin(), nodes.end()));
    if (p.prize.empty()) break;
  }
  return best;
}

// A valid path: starts at 0, distinct nodes, all of them when there are no prizes; its figures
// recomputed.
void ExpectValid(const TourProblem& p, const Tour& t) {
  ASSERT_FALSE(t.order.empty());
  EXPECT_EQ(t.order.front(), 0);
  std::vector<int> sorted = t.order;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_TRUE(std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end());
  if (p.prize.empty()) {
    EXPECT_EQ(static_cast<int>(t.order.size()), p.n);
  }
  const Tour again = EvaluateTour(p, t.order);
  EXPECT_NEAR(again.cost, t.cost, 1e-9);
  EXPECT_NEAR(again.objective, t.objective, 1e-9);
}

TEST(Tour, ExactEqualsEnumeration) {
  for (bool prizes : {false, true}) {
    for (uint32_t seed = 1; seed <= 200; ++seed) {
      const int n = 2 + static_cast<int>(seed % 7);  // 2-8 nodes
      const TourProblem p = RandomProblem(n, seed, prizes);
      const Tour t = SolveTourExact(p);
      ExpectValid(p, t);
      EXPECT_NEAR(t.objective, Enumerate(p), 1e-9) << "seed " << seed << " n " << n;
    }
  }
}

// The heuristic against the optimum, 200 instances of 8-9 nodes each way. Every node visited:
// within 1% on every instance and optimal (to 1e-9) on at least 195 (measured when written: 199,
// worst 0.75%). Prize-collecting, the gap relative to the optimum's w * cost plus its prizes:
// within 12% and optimal on at least 190 (measured: 195, worst 10.5%). The first version (two
// starts, 2-opt and Or-opt only) was optimal on 176 and 180, worst 8% and 17%.
TEST(Tour, HeuristicNearTheOptimum) {
  for (bool prizes : {false, true}) {
    int equal = 0;
    double worst = 0.0;
    for (uint32_t seed = 1; seed <= 200; ++seed) {
      const int n = 8 + static_cast<int>(seed % 2);
      const TourProblem p = RandomProblem(n, 1000 + seed, prizes);
      const Tour exact = SolveTourExact(p);
      const Tour h = SolveTourHeuristic(p);
      ExpectValid(p, h);
      ASSERT_GE(h.objective, exact.objective - 1e-9);
      // Prize-collecting objectives can be negative: the gap relative to the optimum's cost
      // plus its prizes (both >= 0).
      const double scale =
          prizes ? p.cost_weight * exact.cost + (p.cost_weight * exact.cost - exact.objective)
                 : exact.cost;
      const double gap = (h.objective - exact.objective) / std::max(scale, 1e-9);
      worst = std::max(worst, gap);
      EXPECT_LE(gap, prizes ? 0.12 : 0.01) << "seed " << seed << (prizes ? " (prizes)" : "");
      if (h.objective <= exact.objective + 1e-9) ++equal;
    }
    std::printf("heuristic %s: optimal on %d / 200, worst gap %.2f%%\n",
                prizes ? "with prizes" : "every node", equal, 100.0 * worst);
    EXPECT_GE(equal, prizes ? 190 : 195) << (prizes ? "with prizes" : "every node");
  }
}

// The heuristic alone finds the planted optimum of a larger instance: nodes on a line whose
// forward legs are cheap and backward legs dear, so the only good path is 0, 1, ..., n - 1.
TEST(Tour, HeuristicFollowsAPlantedAsymmetricOrder) {
  const int n = 25;
  TourProblem p;
  p.n = n;
  p.cost.assign(static_cast<size_t>(n * n), 0.0);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const int d = std::abs(i - j);
      p.cost[static_cast<size_t>(i * n + j)] = j > i ? d : 10.0 * d;
    }
  }
  const Tour t = SolveTour(p);
  std::vector<int> expected(static_cast<size_t>(n));
  std::iota(expected.begin(), expected.end(), 0);
  EXPECT_EQ(t.order, expected);
  EXPECT_DOUBLE_EQ(t.cost, n - 1.0);
}

// Asymmetry is respected: with c(0, 1) + c(1, 2) cheap and c(0, 2) + c(2, 1) dear the path goes
// 0, 1, 2, even though reversing it would be cheap were the costs symmetric.
TEST(Tour, RespectsDirection) {
  TourProblem p;
  p.n = 3;
  p.cost = {0, 1, 1, 9, 0, 1, 9, 9, 0};
  EXPECT_EQ(SolveTourExact(p).order, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(SolveTourHeuristic(p).order, (std::vector<int>{0, 1, 2}));
  p.cost = {0, 1, 1, 9, 0, 9, 9, 1, 0};
  EXPECT_EQ(SolveTourExact(p).order, (std::vector<int>{0, 2, 1}));
  EXPECT_EQ(SolveTourHeuristic(p).order, (std::vector<int>{0, 2, 1}));
}

// Prize-collecting leaves out a node whose prize does not pay for its detour, and keeps it when
// the prize does.
TEST(Tour, PrizesChooseWhatToVisit) {
  TourProblem p;
  p.n = 3;
  p.cost = {0, 1, 10, 1, 0, 10, 10, 10, 0};
  p.prize = {0, 5, 4};
  EXPECT_EQ(SolveTourExact(p).order, (std::vector<int>{0, 1}));
  EXPECT_EQ(SolveTourHeuristic(p).order, (std::vector<int>{0, 1}));
  p.prize = {0, 5, 12};
  EXPECT_EQ(SolveTourExact(p).order, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(SolveTourHeuristic(p).order, (std::vector<int>{0, 1, 2}));
}

TEST(Tour, Deterministic) {
  const TourProblem p = RandomProblem(30, 7, false);
  const Tour a = SolveTour(p);
  const Tour b = SolveTour(p);
  EXPECT_EQ(a.order, b.order);
  EXPECT_EQ(a.cost, b.cost);
}

TEST(Tour, RejectsInvalidProblems) {
  TourProblem p;
  p.n = 2;
  p.cost = {0, 1, 1};
  EXPECT_THROW((void)SolveTour(p), std::invalid_argument);
  p.cost = {0, -1, 1, 0};
  EXPECT_THROW((void)SolveTour(p), std::invalid_argument);
  p.cost = {0, 1, 1, 0};
  p.prize = {0};
  EXPECT_THROW((void)SolveTour(p), std::invalid_argument);
  p.prize.clear();
  EXPECT_NO_THROW((void)SolveTour(p));
  p.n = kMaxExactTourNodes + 1;
  p.cost.assign(static_cast<size_t>(p.n * p.n), 1.0);
  EXPECT_THROW((void)SolveTourExact(p), std::invalid_argument);
  EXPECT_NO_THROW((void)SolveTourHeuristic(p));
}

}  // namespace
}  // namespace kestrel
