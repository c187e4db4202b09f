#include "exploration/candidates.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace kestrel {
namespace {

// eq. (17): bump(0) = 1, even, decreasing, 0 at and beyond d_max, known interior value.
TEST(Candidates, BumpFunction) {
  EXPECT_EQ(Bump(0.0, 5.0), 1.0);
  EXPECT_EQ(Bump(5.0, 5.0), 0.0);
  EXPECT_EQ(Bump(7.0, 5.0), 0.0);
  EXPECT_EQ(Bump(-2.0, 5.0), Bump(2.0, 5.0));
  EXPECT_NEAR(Bump(2.5, 5.0), std::exp(1.0 - 1.0 / 0.75), 1e-15);
  double prev = 1.0;
  for (double d = 0.1; d < 5.0; d += 0.1) {
    EXPECT_LT(Bump(d, 5.0), prev);
    prev = Bump(d, 5.0);
  }
}

// Section 8: d_max policies.
TEST(Candidates, DMaxPolicies) {
  CandidateConfig c;
  c.d_max_epsilon = 0.1;
  c.d_max_policy = DMaxPolicy::kSimulation;
  EXPECT_NEAR(DMax(c, 8.0), 8.8, 1e-12);
  EXPECT_NEAR(DMax(c, 2.0), 2.2, 1e-12);
  EXPECT_GT(Bump(8.0, DMax(c, 8.0)), 0.0);  // epsilon: the farthest cell keeps a weight
  c.d_max_policy = DMaxPolicy::kExperiment;
  EXPECT_NEAR(DMax(c, 2.0), 5.0, 1e-12);  // d_fixed
  EXPECT_NEAR(DMax(c, 8.0), 8.8, 1e-12);  // grows only past d_fixed
  c.d_max_policy = DMaxPolicy::kSimulation;
  EXPECT_GT(DMax(c, 0.0), 0.0);
  EXPECT_EQ(Bump(0.0, DMax(c, 0.0)), 1.0);
}

// Candidates: one per lattice block of `lattice_step` cells, the lattice cell when reachable,
// else the block's reachable cell nearest to it.
TEST(Candidates, LatticeOfReachableCells) {
  // 5 x 3, column x = 2 blocked except (2, 2): cells right of it reachable through (2, 2) only.
  std::vector<bool> t(15, true);
  t[2] = t[2 + 5] = false;
  t[4 + 5 * 2] = false;  // (4, 2) blocked
  const DistanceField f = ComputeDistanceField(5, 3, t, {0, 0}, 1.0);
  CandidateConfig c;
  const std::vector<int> cells = CandidateCells(f, c);
  // Blocks anchored at x in {0, 2, 4}, y in {0, 2}. (0,0) is the vehicle's: (1,0) and (0,1) are
  // nearest, the lower index wins; (2,0) blocked: (3,0); (4,2) blocked and alone in its block.
  EXPECT_EQ(cells, (std::vector<int>{1, 3, 4, 10, 12}));
  c.exclude_vehicle_cell = false;
  EXPECT_EQ(CandidateCells(f, c), (std::vector<int>{0, 3, 4, 10, 12}));
  c.lattice_step = 1;  // every reachable cell
  EXPECT_EQ(CandidateCells(f, c).size(), 12u);
}

// A corridor one cell wide on an odd row (between lattice rows) has a candidate in every block
// it crosses, and nothing outside it is a candidate.
TEST(Candidates, CorridorBetweenLatticeRows) {
  const int w = 9, h = 4;
  std::vector<bool> t(static_cast<size_t>(w * h), false);
  for (int x = 0; x < w; ++x) t[static_cast<size_t>(x + w * 1)] = true;  // row y = 1
  const DistanceField f = ComputeDistanceField(w, h, t, {0, 1}, 1.0);
  const std::vector<int> cells = CandidateCells(f, CandidateConfig{});
  // Blocks at x0 = 0, 2, 4, 6, 8 (y0 = 0): cells (x0, 1); the vehicle's (0, 1) is excluded and
  // (1, 1) replaces it.
  EXPECT_EQ(cells, (std::vector<int>{1 + w, 2 + w, 4 + w, 6 + w, 8 + w}));
}

// eq. (9): argmax I * bump; the end test uses the best UNWEIGHTED gain.
TEST(Candidates, ChoiceAndEndOfExploration) {
  std::vector<bool> t(10, true);
  const DistanceField f = ComputeDistanceField(10, 1, t, {0, 0}, 1.0);  // d = 0..9 m
  CandidateConfig c;
  c.d_max_policy = DMaxPolicy::kExperiment;
  c.d_fixed_m = 5.0;
  c.d_max_epsilon = 0.0;  // d_max = max(5, 9) = 9
  c.end_gain_nats = 3.0;
  std::vector<Candidate> cands(3);
  cands[0].cell = 1;  // near, small gain
  cands[0].gain_nats = 2.0;
  cands[1].cell = 8;  // far, large gain
  cands[1].gain_nats = 10.0;
  cands[2].cell = 4;
  cands[2].gain_nats = 2.5;
  Choice ch = ChooseCandidate(f, c, &cands);
  const double b1 = Bump(1.0, 9.0), b8 = Bump(8.0, 9.0), b4 = Bump(4.0, 9.0);
  EXPECT_NEAR(cands[1].bump, b8, 1e-15);
  EXPECT_NEAR(cands[1].distance_m, 8.0, 1e-12);
  const double obj[3] = {2.0 * b1, 10.0 * b8, 2.5 * b4};
  int best = 0;
  for (int i = 1; i < 3; ++i) best = obj[i] > obj[best] ? i : best;
  EXPECT_EQ(ch.index, best);
  EXPECT_EQ(best, 0);  // the far candidate is weighted down ...
  EXPECT_EQ(ch.best_unweighted_gain_nats, 10.0);
  EXPECT_FALSE(ch.exploration_done);  // ... but its unweighted gain keeps exploration going
  cands[1].gain_nats = 2.9;
  ch = ChooseCandidate(f, c, &cands);
  EXPECT_TRUE(ch.exploration_done);
  std::vector<Candidate> none;
  EXPECT_TRUE(ChooseCandidate(f, c, &none).exploration_done);
  EXPECT_EQ(ChooseCandidate(f, c, &none).index, -1);
}

}  // namespace
}  // namespace kestrel
