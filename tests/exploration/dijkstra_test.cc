#include "exploration/dijkstra.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace kestrel {
namespace {

// Brute-force oracle: Bellman-Ford relaxation to a fixed point over moves written differently:
// an orthogonal move needs its target usable; a diagonal move needs the whole 2x2 block it
// crosses usable (no corner cutting). The start cell is usable. With weights (one per cell), a
// move costs its length times the mean of its two cells' weights.
std::vector<double> BellmanFord(int w, int h, const std::vector<bool>& t, int start, double a,
                                const std::vector<double>& weight = {}) {
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> d(static_cast<size_t>(w * h), inf);
  d[static_cast<size_t>(start)] = 0.0;
  const auto ok = [&](int x, int y) {
    return x >= 0 && y >= 0 && x < w && y < h &&
           (x + w * y == start || t[static_cast<size_t>(x + w * y)]);
  };
  for (bool changed = true; changed;) {
    changed = false;
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        if (!ok(x, y) || !std::isfinite(d[static_cast<size_t>(x + w * y)])) continue;
        const double dx0 = d[static_cast<size_t>(x + w * y)];
        const int moves[8][2] = {{1, 0}, {-1, 0}, {0, 1},  {0, -1},
                                 {1, 1}, {1, -1}, {-1, 1}, {-1, -1}};
        for (const auto& mv : moves) {
          const int nx = x + mv[0], ny = y + mv[1];
          if (!ok(nx, ny)) continue;
          double cost = a;
          if (mv[0] != 0 && mv[1] != 0) {
            if (!(ok(x, ny) && ok(nx, y))) continue;  // the 2x2 block
            cost = a * std::sqrt(2.0);
          }
          if (!weight.empty()) {
            cost *= 0.5 * (weight[static_cast<size_t>(x + w * y)] +
                           weight[static_cast<size_t>(nx + w * ny)]);
          }
          double& dn = d[static_cast<size_t>(nx + w * ny)];
          if (dx0 + cost < dn - 1e-12) {
            dn = dx0 + cost;
            changed = true;
          }
        }
      }
    }
  }
  return d;
}

// Dijkstra equals Bellman-Ford on random grids, with and without step weights, and its
// back-pointers give legal paths whose (weighted) length is d_cell.
TEST(Dijkstra, MatchesBellmanFordOnRandomGrids) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 800; ++trial) {
    const int w = 1 + static_cast<int>(u(rng) * 14), h = 1 + static_cast<int>(u(rng) * 14);
    const double density = 0.1 + 0.5 * u(rng);
    std::vector<bool> t(static_cast<size_t>(w * h));
    for (size_t i = 0; i < t.size(); ++i) t[i] = u(rng) > density;
    std::vector<double> weight;  // every other trial: weights in [1, 4)
    if (trial % 2 == 1) {
      for (size_t i = 0; i < t.size(); ++i) weight.push_back(1.0 + 3.0 * u(rng));
    }
    const auto weight_at = [&](int i) {
      return weight.empty() ? 1.0 : weight[static_cast<size_t>(i)];
    };
    const Cell2 start{static_cast<int>(u(rng) * w), static_cast<int>(u(rng) * h)};
    const double a = 0.9;
    const DistanceField f = ComputeDistanceField(w, h, t, start, a, weight);
    const std::vector<double> oracle = BellmanFord(w, h, t, start.x + w * start.y, a, weight);
    for (int i = 0; i < w * h; ++i) {
      const double di = f.distance_m[static_cast<size_t>(i)];
      if (std::isinf(oracle[static_cast<size_t>(i)])) {
        ASSERT_TRUE(std::isinf(di)) << trial << " " << i;
        ASSERT_TRUE(f.PathTo(i).empty());
        continue;
      }
      ASSERT_NEAR(di, oracle[static_cast<size_t>(i)], 1e-9) << trial << " " << i;
      const std::vector<int> path = f.PathTo(i);
      ASSERT_EQ(path.front(), f.start);
      ASSERT_EQ(path.back(), i);
      double len = 0.0;
      for (size_t s = 1; s < path.size(); ++s) {
        const int x0 = path[s - 1] % w, y0 = path[s - 1] / w, x1 = path[s] % w, y1 = path[s] / w;
        ASSERT_LE(std::abs(x1 - x0), 1);
        ASSERT_LE(std::abs(y1 - y0), 1);
        ASSERT_TRUE(t[static_cast<size_t>(path[s])]);
        if (x1 != x0 && y1 != y0) {
          ASSERT_TRUE(t[static_cast<size_t>(x1 + w * y0)] || x1 + w * y0 == f.start);
          ASSERT_TRUE(t[static_cast<size_t>(x0 + w * y1)] || x0 + w * y1 == f.start);
        }
        len +=
            std::hypot(x1 - x0, y1 - y0) * a * 0.5 * (weight_at(path[s - 1]) + weight_at(path[s]));
      }
      ASSERT_NEAR(len, di, 1e-9);
    }
  }
}

// No corner cutting: two free cells touching only diagonally between two occupied cells are not
// connected directly.
TEST(Dijkstra, NoDiagonalThroughBlockedCorner) {
  // 2 x 2: free (0,0) and (1,1), blocked (1,0) and (0,1).
  const std::vector<bool> t{true, false, false, true};
  const DistanceField f = ComputeDistanceField(2, 2, t, {0, 0}, 1.0);
  EXPECT_FALSE(f.Reachable(3));
  const std::vector<bool> t2{true, true, false, true};  // one orthogonal neighbour free: still no
  EXPECT_NEAR(ComputeDistanceField(2, 2, t2, {0, 0}, 1.0).distance_m[3], 2.0, 1e-12);
}

// Bad input is rejected with the offending values.
TEST(Dijkstra, RejectsStartOutsideGrid) {
  EXPECT_THROW(ComputeDistanceField(2, 2, std::vector<bool>(4, true), {2, 0}, 1.0),
               std::invalid_argument);
  EXPECT_THROW(ComputeDistanceField(2, 2, std::vector<bool>(3, true), {0, 0}, 1.0),
               std::invalid_argument);
  // Step weights: one per cell, each finite and at least 1.
  const std::vector<bool> t(4, true);
  EXPECT_THROW(ComputeDistanceField(2, 2, t, {0, 0}, 1.0, {1.0, 1.0, 1.0}), std::invalid_argument);
  EXPECT_THROW(ComputeDistanceField(2, 2, t, {0, 0}, 1.0, {1.0, 0.5, 1.0, 1.0}),
               std::invalid_argument);
  EXPECT_THROW(ComputeDistanceField(2, 2, t, {0, 0}, 1.0, {1.0, 1.0, std::nan(""), 1.0}),
               std::invalid_argument);
}

}  // namespace
}  // namespace kestrel
