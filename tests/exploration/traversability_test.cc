// Fine traversability (exploration/traversability.h): the distance transform against brute force,
// gaps passable wherever they lie, unknown space blocked, the band, the start-up zone and the
// flown corridor.
#include "exploration/traversability.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <vector>

#include "exploration/dijkstra.h"
#include "tests/exploration/test_input.h"

namespace kestrel {
namespace {

constexpr double kAlpha = 0.075;
constexpr float kFree = 1e-4f;
constexpr float kOccupied = 0.9999f;

// A 3D map of nx x ny x nz cells from (0, 0, 0), every cell `fill`.
struct TestMap {
  Eigen::Vector3i dims;
  std::vector<float> p;
  TestMap(int nx, int ny, int nz, float fill)
      : dims(nx, ny, nz), p(static_cast<size_t>(nx) * ny * nz, fill) {}
  float& at(int i, int j, int k) {
    return p[static_cast<size_t>(i) + static_cast<size_t>(dims.x()) * (j + dims.y() * k)];
  }
  // Sets every cell whose centre lies in the box [lo, hi) (m).
  void Box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, float value) {
    for (int k = 0; k < dims.z(); ++k) {
      for (int j = 0; j < dims.y(); ++j) {
        for (int i = 0; i < dims.x(); ++i) {
          const Eigen::Vector3d c((i + 0.5) * kAlpha, (j + 0.5) * kAlpha, (k + 0.5) * kAlpha);
          if ((c.array() >= lo.array()).all() && (c.array() < hi.array()).all())
            at(i, j, k) = value;
        }
      }
    }
  }
  OccupancyGridView View() const {
    OccupancyGridView v;
    v.dims = dims;
    v.origin_m = Eigen::Vector3d::Zero();
    v.resolution_m = kAlpha;
    v.probability = p.data();
    return v;
  }
};

TraversabilityConfig Config(double h) {
  TraversabilityConfig c;
  c.height_m = h;
  c.band_below_m = 0.2;
  c.band_above_m = 0.2;
  c.vehicle_radius_m = 0.44;
  c.margin_m = 0.10;
  c.passage_margin_m = 0.08;
  return c;
}

using test::Reachable;  // over the traversable cells and the passages

TEST(SquaredDistanceTransform, EqualsBruteForce) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const int w = 1 + static_cast<int>(rng() % 23);
    const int h = 1 + static_cast<int>(rng() % 19);
    std::vector<bool> site(static_cast<size_t>(w * h));
    const double density = (trial % 4) * 0.1;
    for (size_t i = 0; i < site.size(); ++i) {
      site[i] = std::uniform_real_distribution<double>(0, 1)(rng) < density;
    }
    const std::vector<double> d2 = SquaredDistanceTransform(w, h, site);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        double best = std::numeric_limits<double>::infinity();
        for (int v = 0; v < h; ++v) {
          for (int u = 0; u < w; ++u) {
            if (site[static_cast<size_t>(u + w * v)]) {
              best = std::min(best, static_cast<double>((u - x) * (u - x) + (v - y) * (v - y)));
            }
          }
        }
        ASSERT_EQ(d2[static_cast<size_t>(x + w * y)], best)
            << "trial " << trial << " cell " << x << ", " << y;
      }
    }
  }
}

// A wall across the room with one gap at an arbitrary offset (not on any lattice), n whole free
// cells wide: 15 (1.125 m) pass the 0.88 m vehicle through a cell centre with 0.10 m of margin a
// side, 14 (1.05 m) through a passage point (the middle of the gap) with a passage margin of
// 0.08 m, 13 (0.975 m) not with that margin (the shipped 0.0125 m opens them: the angle tests).
TEST(Traversability, GapPassableWhereverItLies) {
  for (const int n : {13, 14, 15}) {
    for (const double offset : {1.237, 2.0, 2.561}) {
      TestMap m(100, 80, 24, kFree);  // 7.5 x 6 x 1.8 m, all known free
      const double x0 = std::floor(offset / kAlpha) * kAlpha;
      const double x1 = x0 + n * kAlpha;
      m.Box({0, 2.95, 0}, {x0, 3.1, 1.8}, kOccupied);
      m.Box({x1, 2.95, 0}, {7.5, 3.1, 1.8}, kOccupied);
      const Traversability t = ComputeTraversability(m.View(), Config(1.0));
      const bool pass = Reachable(t, {0.5 * (x0 + x1), 1.2}, {0.5 * (x0 + x1), 4.8});
      EXPECT_EQ(pass, n >= 14) << n << " cells at x " << x0;
      // Passage points on the gap's middle line; within the wall's thickness only in the even
      // gap (outside it the middle line's clearance grows past the passage clearance in all).
      int in_wall = 0;
      for (const auto& [cell, point] : t.passage_points) {
        EXPECT_NEAR(point.x(), 0.5 * (x0 + x1), 1e-3) << "cell " << cell;
        if (point.y() > 2.925 && point.y() < 3.15) ++in_wall;
      }
      EXPECT_EQ(in_wall > 0, n == 14) << n << " cells at x " << x0;
    }
  }
}

// Passage cells (file comment, step 3b) against brute force on random clutter: every passage
// point lies in its cell, a free cell that is not traversable; its clearance, measured to every
// blocked square's surface (the map's outside included), is the one stored and at least radius +
// passage margin; its nearest surface on the far side (more than 110 deg away) is within 2 alpha/10
// of the nearest (a middle line); and its tolerance across is min(alpha/2, clearance - radius).
TEST(Traversability, PassagesHoldTheirRuleOnClutter) {
  std::mt19937 rng(11);
  int passages = 0;
  for (int trial = 0; trial < 12; ++trial) {
    const int w = 30 + static_cast<int>(rng() % 20);
    const int h = 30 + static_cast<int>(rng() % 20);
    TestMap m(w, h, 24, kFree);
    std::uniform_real_distribution<double> ux(0, w * kAlpha), uy(0, h * kAlpha);
    for (int b = 0; b < 6; ++b) {  // walls and pillars, some a gap of 13 or 14 cells apart
      const double x = ux(rng), y = uy(rng);
      const double ex = (rng() % 2) ? 0.15 : 1.5, ey = (rng() % 2) ? 0.15 : 1.5;
      m.Box({x, y, 0}, {x + ex, y + ey, 1.8}, kOccupied);
      const double gap = (13 + rng() % 2) * kAlpha;
      if (rng() % 2) m.Box({x + ex + gap, y, 0}, {x + 2 * ex + gap, y + ey, 1.8}, kOccupied);
    }
    const TraversabilityConfig c = Config(1.0);
    const Traversability t = ComputeTraversability(m.View(), c);
    // Blocked squares' lower corners, the ring around the map included, m.
    std::vector<Eigen::Vector2d> blocked;
    for (int y = -1; y <= h; ++y) {
      for (int x = -1; x <= w; ++x) {
        if (x < 0 || y < 0 || x >= w || y >= h ||
            t.band.values[static_cast<size_t>(x + w * y)] > c.free_threshold) {
          blocked.emplace_back(x * kAlpha, y * kAlpha);
        }
      }
    }
    const auto nearest = [&](const Eigen::Vector2d& p, const Eigen::Vector2d* toward) {
      double best = std::numeric_limits<double>::infinity();
      Eigen::Vector2d at = p;
      for (const Eigen::Vector2d& lo : blocked) {
        const Eigen::Vector2d a(std::clamp(p.x(), lo.x(), lo.x() + kAlpha),
                                std::clamp(p.y(), lo.y(), lo.y() + kAlpha));
        const double d = (a - p).norm();
        if (toward != nullptr && (a - p).dot(*toward - p) >= -0.34 * d * (*toward - p).norm()) {
          continue;
        }
        if (d < best) {
          best = d;
          at = a;
        }
      }
      return std::pair{best, at};
    };
    ASSERT_EQ(t.passage_points.size(), t.passage_across.size());
    for (const auto& [cell, point] : t.passage_points) {
      const size_t i = static_cast<size_t>(cell);
      const Cell2 xy = t.band.CellAt(cell);
      EXPECT_LE(t.band.values[i], c.free_threshold);
      EXPECT_FALSE(t.traversable[i]);
      EXPECT_EQ(t.band.CellOf(point).value_or(Cell2{-1, -1}), xy) << "cell " << cell;
      const auto [d1, a1] = nearest(point, nullptr);
      EXPECT_NEAR(t.clearance.values[i], d1, 1e-9) << "cell " << cell;
      EXPECT_GE(d1, c.passage_clearance_m()) << "cell " << cell;
      const auto [d2, a2] = nearest(point, &a1);
      EXPECT_LE(d2 - d1, 0.2 * kAlpha + 1e-9) << "cell " << cell;
      const PassageAcross& across = t.passage_across.at(cell);
      // The normal points at a nearest surface (either one where two are as near).
      EXPECT_NEAR(across.normal.norm(), 1.0, 1e-9);
      EXPECT_NEAR(nearest(point + d1 * across.normal, nullptr).first, 0.0, 1e-9);
      EXPECT_NEAR(across.tolerance_m, std::min(0.5 * kAlpha, d1 - c.vehicle_radius_m), 1e-9);
    }
    passages += static_cast<int>(t.passage_points.size());
  }
  EXPECT_GT(passages, 0);  // the clutter made some
}

// The preferred clearance's step weights (file comment, step 4): 1 where a cell has the preferred
// clearance, 1 + weight at the required one and below, the square of the shortfall between; none
// when either parameter is 0.
TEST(Traversability, StepWeightsFollowTheClearanceShortfall) {
  TestMap m(80, 80, 24, kFree);
  m.Box({0, 0, 0}, {6.0, 0.9, 1.8}, kOccupied);  // a wall along the south side
  TraversabilityConfig c = Config(1.0);
  c.preferred_extra_m = 0.3;
  c.clearance_weight = 2.0;
  const Traversability t = ComputeTraversability(m.View(), c);
  const std::vector<double> w = ClearanceStepWeights(t, c);
  ASSERT_EQ(w.size(), t.clearance.values.size());
  const double required = c.required_clearance_m(), preferred = required + 0.3;
  int below = 0, between = 0, above = 0;
  for (size_t i = 0; i < w.size(); ++i) {
    const double clearance = t.clearance.values[i];
    if (clearance <= required) {
      EXPECT_DOUBLE_EQ(w[i], 3.0) << i;
      ++below;
    } else if (clearance >= preferred) {
      EXPECT_DOUBLE_EQ(w[i], 1.0) << i;
      ++above;
    } else {
      const double s = (preferred - clearance) / 0.3;
      EXPECT_NEAR(w[i], 1.0 + 2.0 * s * s, 1e-12) << i;
      ++between;
    }
  }
  EXPECT_GT(below, 0);
  EXPECT_GT(between, 0);
  EXPECT_GT(above, 0);
  c.clearance_weight = 0.0;
  EXPECT_TRUE(ClearanceStepWeights(t, c).empty());
  c.clearance_weight = 2.0;
  c.preferred_extra_m = 0.0;
  EXPECT_TRUE(ClearanceStepWeights(t, c).empty());
}

TEST(Traversability, UnknownBlocksAndClearanceIsToTheFace) {
  TestMap m(80, 80, 24, 0.1f);                   // unknown everywhere
  m.Box({1.5, 1.5, 0}, {4.5, 4.5, 1.8}, kFree);  // a known-free 3 m square
  const Traversability t = ComputeTraversability(m.View(), Config(1.0));
  const auto centre = t.band.CellOf({3.0, 3.0});
  ASSERT_TRUE(centre.has_value());
  // Centre cell (centre 3.0375): 4.5 - 3.0375 m to the nearest unknown face.
  EXPECT_NEAR(t.clearance.at(*centre), 4.5 - 3.0375, 1e-9);
  EXPECT_TRUE(t.traversable[static_cast<size_t>(t.band.IndexOf(*centre))]);
  // Within radius + margin of the unknown: not traversable; unknown cells flagged as unknown.
  const auto edge = t.band.CellOf({1.8, 3.0});
  EXPECT_FALSE(t.traversable[static_cast<size_t>(t.band.IndexOf(*edge))]);
  const auto outside = t.band.CellOf({0.5, 3.0});
  EXPECT_TRUE(t.unknown[static_cast<size_t>(t.band.IndexOf(*outside))]);
  EXPECT_FALSE(t.unknown[static_cast<size_t>(t.band.IndexOf(*centre))]);
}

// Clutter below the band does not block; anything reaching into the band does.
TEST(Traversability, OnlyTheBandCounts) {
  TestMap m(80, 80, 24, kFree);
  m.Box({2.0, 2.0, 0}, {3.0, 3.0, 0.6}, kOccupied);   // a crate, top 0.6 m < 1.0 - 0.2
  m.Box({4.0, 4.0, 0}, {5.0, 5.0, 0.85}, kOccupied);  // a cabinet reaching 0.85 m > 0.8
  const Traversability t = ComputeTraversability(m.View(), Config(1.0));
  const auto crate = t.band.CellOf({2.5, 2.5});
  const auto cabinet = t.band.CellOf({4.5, 4.5});
  EXPECT_TRUE(t.traversable[static_cast<size_t>(t.band.IndexOf(*crate))]);
  EXPECT_FALSE(t.traversable[static_cast<size_t>(t.band.IndexOf(*cabinet))]);
}

TEST(Traversability, StartupZoneFreesOnlyCellsWithoutEvidence) {
  TestMap m(80, 80, 24, 0.1f);
  m.Box({2.7, 3.3, 0}, {2.9, 3.5, 1.8}, 0.3f);  // weak evidence of occupancy inside the zone
  const StartupFreeZone zone{{3.0, 3.0}, 1.5};
  const Traversability t = ComputeTraversability(m.View(), Config(1.0), zone);
  const auto c = t.band.CellOf({3.0, 3.0});
  const auto evidence = t.band.CellOf({2.8, 3.4});
  const auto far = t.band.CellOf({5.0, 3.0});
  EXPECT_GT(t.clearance.at(*c), 0.25);  // freed: up to the weak evidence, 0.3 m away
  EXPECT_EQ(t.clearance.at(*evidence), 0.0);
  EXPECT_EQ(t.clearance.at(*far), 0.0);
}

// The flown corridor (the flight along y = 1.5 m, through a 0.6 m band of uncertain cells that
// blocks the whole width without it): uncertain cells are freed; occupied cells whose square lay
// inside the vehicle's disc along the path are carved (noise: the body has been there); other
// known obstacles keep the vehicle's radius, not the margin.
TEST(Traversability, FlownCorridorFreesUncertainAndCarvesWhereTheBodyWas) {
  TestMap m(100, 40, 24, kFree);
  m.Box({3.0, 0, 0}, {3.6, 3.0, 1.8}, 0.3f);
  std::vector<Eigen::Vector2d> flown;
  for (double x = 0.8; x <= 6.7; x += 0.25) flown.emplace_back(x, 1.5);
  const Traversability blocked = ComputeTraversability(m.View(), Config(1.0));
  EXPECT_FALSE(Reachable(blocked, {1.0, 1.5}, {6.5, 1.5}));
  const Traversability home = ComputeTraversability(m.View(), Config(1.0), std::nullopt, &flown);
  EXPECT_TRUE(Reachable(home, {1.0, 1.5}, {6.5, 1.5}));

  // Known occupied noise on the flown line (centres within 0.3 m of it): carved.
  TestMap noisy = m;
  noisy.Box({3.0, 1.2, 0}, {3.6, 1.8, 1.8}, kOccupied);
  EXPECT_TRUE(Reachable(ComputeTraversability(noisy.View(), Config(1.0), std::nullopt, &flown),
                        {1.0, 1.5}, {6.5, 1.5}));

  // A post (one column of cells, centre 0.4875 m from the line: outside the carve, 0.44 - 0.053
  // - 0.02 = 0.367 m) on one side: the cells beside the line (j = 19, centre 1.4625) keep the
  // radius (clearance 7 cells - 1/2 = 0.4875 m) though not the margin (0.52 m): passable.
  TestMap post = m;
  post.Box({3.3, 1.95, 0}, {3.375, 2.0, 1.8}, kOccupied);  // cell j = 26, centre y = 1.9875
  const Traversability one_side =
      ComputeTraversability(post.View(), Config(1.0), std::nullopt, &flown);
  EXPECT_TRUE(Reachable(one_side, {1.0, 1.5}, {6.5, 1.5}));
  for (size_t i = 0; i < one_side.traversable.size(); ++i) {
    if (!one_side.traversable[i]) continue;
    const Eigen::Vector2d c = one_side.band.CenterOf(one_side.band.CellAt(static_cast<int>(i)));
    // The post's face (its cell's square) stays at least the radius away, less the transform's
    // sqrt(2)-1 half-cell on diagonals.
    const double dx = std::max({3.3 - c.x(), 0.0, c.x() - 3.375});
    const double dy = std::max({1.95 - c.y(), 0.0, c.y() - 2.025});
    EXPECT_GE(std::hypot(dx, dy), 0.44 - 0.5 * kAlpha * (std::sqrt(2.0) - 1.0) - 1e-9)
        << c.transpose();
  }
  // Posts on both sides 0.4875 m from the line (faces 0.9 m apart for the 0.88 m vehicle): no
  // cell keeps the radius from both, closed whatever the flight says.
  TestMap gap = post;
  gap.Box({3.3, 1.0, 0}, {3.375, 1.05, 1.8}, kOccupied);  // cell j = 13, centre y = 1.0125
  EXPECT_FALSE(Reachable(ComputeTraversability(gap.View(), Config(1.0), std::nullopt, &flown),
                         {1.0, 1.5}, {6.5, 1.5}));
}

TEST(Traversability, InvalidConfigNamesTheField) {
  TestMap m(10, 10, 10, kFree);
  TraversabilityConfig c = Config(0.4);
  c.band_below_m = 0.0;
  try {
    (void)ComputeTraversability(m.View(), c);
    FAIL() << "no throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("band_below_m"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace kestrel
