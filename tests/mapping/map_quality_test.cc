#include "mapping/map_quality.h"

#include <gtest/gtest.h>

#include <cmath>

namespace kestrel {
namespace {

// Six cells, one not observable, worked by hand with P_init = 0.1:
//   cell  P     truth  observable  known (P < 0.05 or P > 0.5)  correct
//   0     0.9   1      1           yes                         yes
//   1     0.02  0      1           yes                         yes
//   2     0.6   0      1           yes                         no
//   3     0.1   1      1           no                          -
//   4     0.3   0      1           no                          -
//   5     0.99  0      0           (not observable)
// known fraction 3/5; accuracy 2/3;
// Brier = (0.01 + 0.0004 + 0.36 + 0.81 + 0.09) / 5 = 1.2704 / 5 = 0.25408;
// AUC: positives {0.9, 0.1}, negatives {0.02, 0.6, 0.3}; pairs won: 0.9 beats all 3,
// 0.1 beats 0.02 only -> 4 of 6 = 2/3.
TEST(MapQuality, MatchesHandComputedExample) {
  const std::vector<double> p{0.9, 0.02, 0.6, 0.1, 0.3, 0.99};
  const std::vector<uint8_t> truth{1, 0, 0, 1, 0, 0};
  const std::vector<uint8_t> observable{1, 1, 1, 1, 1, 0};
  const MapQuality q = ComputeMapQuality(p, truth, observable, 0.1);
  EXPECT_EQ(q.observable_cells, 5u);
  EXPECT_EQ(q.known_cells, 3u);
  EXPECT_DOUBLE_EQ(q.known_fraction, 0.6);
  EXPECT_DOUBLE_EQ(q.accuracy, 2.0 / 3.0);
  EXPECT_NEAR(q.brier, 0.25408, 1e-15);
  EXPECT_DOUBLE_EQ(q.roc_auc, 2.0 / 3.0);
}

// Ties count one half in the AUC, and the "observed at all" rule replaces the threshold rule
// (OctoMap-style maps whose lower clamp 0.12 is above P_init/2):
//   P {0.5, 0.5, 0.12, 0.97}, truth {1, 0, 0, 1}, observed {1, 0, 1, 1}.
//   known: cells 0, 2, 3 -> 3/4; correct: cell 0 (0.5 is not > 0.5, truth 1) wrong, 2 and 3
//   right -> 2/3. AUC: positives {0.5, 0.97}, negatives {0.5, 0.12}: 0.5 vs 0.5 tie (1/2),
//   0.5 > 0.12, 0.97 beats both -> 3.5/4.
TEST(MapQuality, TiesAndObservedRule) {
  const std::vector<double> p{0.5, 0.5, 0.12, 0.97};
  const std::vector<uint8_t> truth{1, 0, 0, 1};
  const std::vector<uint8_t> observable{1, 1, 1, 1};
  const std::vector<uint8_t> observed{1, 0, 1, 1};
  const MapQuality q = ComputeMapQuality(p, truth, observable, 0.1, &observed);
  EXPECT_DOUBLE_EQ(q.known_fraction, 0.75);
  EXPECT_DOUBLE_EQ(q.accuracy, 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(q.roc_auc, 3.5 / 4.0);
  EXPECT_NEAR(q.brier, (0.25 + 0.25 + 0.0144 + 0.0009) / 4.0, 1e-15);
}

// A perfect map scores AUC 1, accuracy 1, Brier 0; one class only gives an undefined AUC.
TEST(MapQuality, PerfectAndDegenerateMaps) {
  const std::vector<uint8_t> truth{1, 0, 1, 0};
  const std::vector<uint8_t> all{1, 1, 1, 1};
  const MapQuality q = ComputeMapQuality({1.0, 0.0, 1.0, 0.0}, truth, all, 0.1);
  EXPECT_DOUBLE_EQ(q.roc_auc, 1.0);
  EXPECT_DOUBLE_EQ(q.accuracy, 1.0);
  EXPECT_DOUBLE_EQ(q.brier, 0.0);
  const MapQuality one_class = ComputeMapQuality({0.2, 0.3}, {0, 0}, {1, 1}, 0.1);
  EXPECT_TRUE(std::isnan(one_class.roc_auc));
  EXPECT_TRUE(std::isnan(one_class.accuracy));  // nothing known
  EXPECT_THROW(static_cast<void>(ComputeMapQuality({0.2}, {0, 0}, {1, 1}, 0.1)),
               std::invalid_argument);
}

}  // namespace
}  // namespace kestrel
