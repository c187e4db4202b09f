#include "mapping/inverse_sensor_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "mapping/kernels/kernels.h"
#include "mapping/lanes.h"
#include "mapping/ray_caster.h"

namespace kestrel {
namespace {

constexpr double kPmin = 1e-4;

// Brute-force oracle (docs/algorithms.md §4.4): enumerate all 2^n occupancy patterns, weight
// each by its prior product and by p(z | pattern) from its first occupied cell, and return the
// posterior marginal of every cell.
std::vector<double> BruteForcePosteriors(const SensorModel& model, const Reading& reading,
                                         const std::vector<double>& d,
                                         const std::vector<double>& prior) {
  const int n = static_cast<int>(d.size());
  std::vector<double> occupied_mass(n, 0.0);
  double total = 0.0;
  for (uint32_t pattern = 0; pattern < (1u << n); ++pattern) {
    double weight = 1.0;
    int first = -1;
    for (int k = 0; k < n; ++k) {
      const bool occ = (pattern >> k) & 1u;
      weight *= occ ? prior[k] : 1.0 - prior[k];
      if (occ && first < 0) first = k;
    }
    double likelihood;
    if (reading.kind == ReadingKind::kReturn) {
      likelihood =
          first < 0 ? model.EmptyRayLikelihood(reading) : model.ReturnLikelihood(reading, d[first]);
    } else {
      likelihood =
          first < 0 ? model.empty_no_return_probability() : model.NoReturnProbability(d[first]);
    }
    const double joint = weight * likelihood;
    total += joint;
    for (int k = 0; k < n; ++k) {
      if ((pattern >> k) & 1u) occupied_mass[k] += joint;
    }
  }
  for (double& m : occupied_mass) m /= total;
  return occupied_mass;
}

// A real ray's distances: cast a random ray through the paper's lattice and keep n cells from a
// random start, so that d_k spans near cells, the range and beyond.
std::vector<double> RandomDistances(std::mt19937& rng, int n, double start_m, double spacing_m) {
  std::vector<double> d(n);
  std::uniform_real_distribution<double> jitter(0.2, 1.0);
  double t = start_m;
  for (int k = 0; k < n; ++k) {
    d[k] = t;
    t += spacing_m * jitter(rng);
  }
  return d;
}

std::vector<double> RandomPriors(std::mt19937& rng, int n) {
  std::vector<double> p(n);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  for (int k = 0; k < n; ++k) {
    switch (rng() % 5) {
      case 0:
        p[k] = kPmin;  // clamp bounds
        break;
      case 1:
        p[k] = 1.0 - kPmin;
        break;
      case 2:
        p[k] = 0.1;  // P_init
        break;
      default:
        p[k] = uni(rng);
    }
  }
  return p;
}

void ExpectMatchesBruteForce(const SensorModel& model, const Reading& reading,
                             const std::vector<double>& d, const std::vector<double>& prior) {
  const int n = static_cast<int>(d.size());
  InverseSensorModelScratch scratch(n + 1);
  const double kUnwritten = -7.0;
  std::vector<double> posterior(n, kUnwritten);
  const ExactUpdateResult r =
      ComputeExactPosteriors(model, reading, d.data(), prior.data(), n, posterior.data(), &scratch);
  const std::vector<double> expected = BruteForcePosteriors(model, reading, d, prior);
  for (int k = 0; k < n; ++k) {
    const bool written = k >= r.first && k < r.first + r.count;
    if (reading.kind == ReadingKind::kNoReturn) {
      // No return: exactly the cells with d_k >= z_min are written.
      ASSERT_EQ(written, d[k] >= model.config().z_min_m) << "k = " << k;
    } else if (reading.surface_unknown) {
      // Only the cells before the band's near end are written.
      ASSERT_EQ(written, d[k] < reading.z_m - reading.below_m) << "k = " << k;
    } else if (d[k] <= model.GaussianReach(reading.z_m)) {  // the band lies before z
      ASSERT_TRUE(written) << "k = " << k;
    }
    if (written) {
      ASSERT_NEAR(posterior[k], expected[k], 1e-12) << "k = " << k << " n = " << n;
    } else {
      ASSERT_EQ(posterior[k], kUnwritten);
      if (reading.kind == ReadingKind::kReturn) {
        // Left out by the shortcut: exact under the windowed model, the posterior is the prior.
        ASSERT_NEAR(expected[k], prior[k], 1e-12) << "k = " << k;
      }
    }
  }
}

// The O(n_r) update equals 2^n_r enumeration to 1e-12 for random priors (clamp bounds
// included), random returns, z at z_min and just below z_max, no-return readings, near cells
// and n_r = 1, for both paper sensors.
TEST(InverseSensorModel, MatchesBruteForceEnumeration) {
  std::mt19937 rng(1234);
  for (const SensorModelConfig& config :
       {SensorModelConfig::PaperXtion(), SensorModelConfig::PaperHokuyo()}) {
    const SensorModel model(config);
    for (int trial = 0; trial < 300; ++trial) {
      const int n = 1 + static_cast<int>(rng() % 14);
      // Spacing chosen so that rays cover near cells (< z_min), the range, and the far tail.
      const double start = std::uniform_real_distribution<double>(0.0, 3.5)(rng);
      const double spacing = std::uniform_real_distribution<double>(0.02, 0.4)(rng);
      const std::vector<double> d = RandomDistances(rng, n, start, spacing);
      const std::vector<double> prior = RandomPriors(rng, n);
      Reading reading;
      switch (trial % 5) {
        case 0:
          reading = {ReadingKind::kNoReturn, 0.0};
          break;
        case 1:
          reading = {ReadingKind::kReturn, config.z_min_m};
          break;
        case 2:
          reading = {ReadingKind::kReturn, std::nextafter(config.z_max_m, 0.0)};
          break;
        case 3:  // a return right at one cell of the ray
          reading = {ReadingKind::kReturn,
                     std::min(std::max(d[rng() % n], config.z_min_m), config.z_max_m - 1e-9)};
          break;
        default:
          reading = model.Classify(
              std::uniform_real_distribution<double>(config.z_min_m, config.z_max_m)(rng));
      }
      ExpectMatchesBruteForce(model, reading, d, prior);
      if (HasFatalFailure()) return;
    }
  }
}

// Returns with a range band (docs/algorithms.md §3.8): the O(n_r) update still equals 2^n_r
// enumeration under the banded likelihood, and no cell inside the band [z - below, z] (and in
// range) loses probability: a return whose direction is uncertain frees nothing it may have met.
TEST(InverseSensorModel, RangeBandsMatchBruteForceAndFreeNothingInTheBand) {
  std::mt19937 rng(4321);
  for (SensorModelConfig config : {SensorModelConfig::Xtion(), SensorModelConfig::PaperHokuyo()}) {
    for (const bool tables : {true, false}) {
      config.interpolated_gaussian = tables;
      const SensorModel model(config);
      int band_cells = 0;
      for (int trial = 0; trial < 300; ++trial) {
        const int n = 1 + static_cast<int>(rng() % 14);
        const double start = std::uniform_real_distribution<double>(0.0, 3.0)(rng);
        const double spacing = std::uniform_real_distribution<double>(0.02, 0.3)(rng);
        const std::vector<double> d = RandomDistances(rng, n, start, spacing);
        const std::vector<double> prior = RandomPriors(rng, n);
        const double z =
            std::uniform_real_distribution<double>(config.z_min_m, config.z_max_m)(rng);
        Reading reading = model.Classify(z);
        reading.below_m = std::uniform_real_distribution<double>(0.0, 2.0)(rng);
        reading.surface_unknown = trial % 3 == 0;
        ExpectMatchesBruteForce(model, reading, d, prior);
        if (HasFatalFailure()) return;
        InverseSensorModelScratch scratch(n + 1);
        std::vector<double> posterior(prior);
        ComputeExactPosteriors(model, reading, d.data(), prior.data(), n, posterior.data(),
                               &scratch);
        for (int k = 0; k < n; ++k) {
          // In the band and in the sensor's range (a surface nearer than z_min gives no return).
          if (d[k] >= std::max(reading.z_m - reading.below_m, config.z_min_m) &&
              (d[k] <= reading.z_m || reading.surface_unknown)) {
            ++band_cells;
            EXPECT_GE(posterior[k], prior[k] * (1.0 - 1e-6)) << "k = " << k << " d = " << d[k];
          }
        }
      }
      EXPECT_GT(band_cells, 100);
    }
  }
}

// The banded likelihood: 1/(1 + w/(sigma sqrt(2 pi))) of the plain peak anywhere in the band,
// the plain Gaussian of the distance to the band outside it, the plain model without a band.
TEST(SensorModel, RangeBandIsAPlateauOfTheGaussian) {
  SensorModelConfig config = SensorModelConfig::Xtion();
  config.interpolated_gaussian = false;
  const SensorModel model(config);
  const double sigma = config.sigma_m, z = 3.0, w = 0.5;
  const Reading plain{ReadingKind::kReturn, z};
  const Reading banded{ReadingKind::kReturn, z, w};
  const double scale = 1.0 / (1.0 + w / (sigma * std::sqrt(2.0 * M_PI)));
  EXPECT_DOUBLE_EQ(model.BandScale(banded), scale);
  const double u = model.spurious_density();
  // ReturnLikelihood(d + r, d) - u is the plain Gaussian term at distance r from d.
  for (const double d : {z - w, z - 0.3, z - 0.01, z}) {
    EXPECT_NEAR(model.ReturnLikelihood(banded, d) - u, scale * (model.ReturnLikelihood(d, d) - u),
                1e-12)
        << "d = " << d;
  }
  for (const double off : {0.05, 0.2}) {
    const double d = z - w - off;  // nearer than the band: the distance to its near end
    EXPECT_NEAR(model.ReturnLikelihood(banded, d) - u,
                scale * (model.ReturnLikelihood(d + off, d) - u), 1e-12);
    EXPECT_NEAR(model.ReturnLikelihood(banded, z + off) - u,  // beyond z: as without a band
                scale * (model.ReturnLikelihood(plain, z + off) - u), 1e-12);
  }
  EXPECT_EQ(model.ReturnLikelihood(plain, 2.5), model.ReturnLikelihood(z, 2.5));
}

// The same with the untruncated Gaussian (cutoff +inf): nothing is left out and the algebra
// still matches enumeration.
TEST(InverseSensorModel, MatchesBruteForceWithoutGaussianWindow) {
  SensorModelConfig config = SensorModelConfig::PaperXtion();
  config.cutoff_sigmas = std::numeric_limits<double>::infinity();
  const SensorModel model(config);
  std::mt19937 rng(99);
  for (int trial = 0; trial < 100; ++trial) {
    const int n = 1 + static_cast<int>(rng() % 14);
    const std::vector<double> d = RandomDistances(rng, n, 0.3, 0.3);
    const std::vector<double> prior = RandomPriors(rng, n);
    const Reading reading = model.Classify(std::uniform_real_distribution<double>(0.5, 4.0)(rng));
    ExpectMatchesBruteForce(model, reading, d, prior);
    if (HasFatalFailure()) return;
  }
}

// The forward pass works in blocks of eight cells (docs/algorithms.md §4.7): rays of 16 cells whose
// leading run (10 cells), Gaussian window (12 cells) or "no return" in-range run (12 cells) span
// more than one block and end inside one still match enumeration.
TEST(InverseSensorModel, MatchesBruteForceAcrossBlocksOfEightCells) {
  const SensorModel model(SensorModelConfig::PaperXtion());  // window 2 x 1.25 m
  std::mt19937 rng(18);
  constexpr int kN = 16;
  std::vector<double> d(kN);
  for (int k = 0; k < kN; ++k) d[k] = 0.3 + 0.06 * k;  // 0.3 .. 1.2 m, 4 cells below z_min
  for (const Reading& reading : {Reading{ReadingKind::kReturn, 2.1},  // run d < 0.85: 10
                                 Reading{ReadingKind::kReturn, 1.7},  // run d < 0.5: 4
                                 Reading{ReadingKind::kNoReturn, 0.0}}) {
    ExpectMatchesBruteForce(model, reading, d, RandomPriors(rng, kN));
    if (HasFatalFailure()) return;
  }
}

// n_r = 1 by hand: P' = P a_1 / (P a_1 + (1-P) p_rand u).
TEST(InverseSensorModel, SingleCellByHand) {
  const SensorModel model(SensorModelConfig::PaperXtion());
  InverseSensorModelScratch scratch(1);
  const double d = 2.0;
  const double prior = 0.1;
  double posterior = -1.0;
  const Reading z{ReadingKind::kReturn, 2.1};
  ComputeExactPosteriors(model, z, &d, &prior, 1, &posterior, &scratch);
  const double sigma = 0.25;
  const double mass = std::erf((4.0 - d) / (sigma * std::sqrt(2.0))) / 2.0 +
                      std::erf((d - 0.5) / (sigma * std::sqrt(2.0))) / 2.0;
  const double g = std::exp(-0.5 * 0.01 / (sigma * sigma)) / (sigma * std::sqrt(2.0 * M_PI)) / mass;
  const double a1 = 0.1 / 3.5 + 0.9 * 0.95 * g;
  const double a_empty = 0.1 / 3.5;
  EXPECT_NEAR(posterior, prior * a1 / (prior * a1 + (1.0 - prior) * a_empty), 1e-14);
}

// The shortcut against the untruncated model (cutoff +inf, every cell kept): every posterior
// moves by at most the bound that follows from perturbing each likelihood a_k by a relative eps
// (numerator and denominator of P'_k are sums of non-negative pi-weighted a's, so
// |P'_c - P'_inf| <= P'_inf * 2 eps / (1 - eps)), and eps is small for c = 5: at most the
// Gaussian at 5 sigma over the spurious term, 0.9*0.95*phi(5)/(sigma D) / (p_rand u) < 1e-3.
TEST(InverseSensorModel, TruncationIsBoundedAgainstUntruncatedUpdate) {
  SensorModelConfig full_config = SensorModelConfig::PaperXtion();
  full_config.cutoff_sigmas = std::numeric_limits<double>::infinity();
  const SensorModel full(full_config);
  const SensorModel cut(SensorModelConfig::PaperXtion());
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  RayCells ray(4.0, g.resolution_m());
  const RayCaster caster(g);
  InverseSensorModelScratch scratch(ray.cells.size());
  std::mt19937 rng(8);
  double worst_eps = 0.0;
  int cells_left_out = 0;
  for (int trial = 0; trial < 500; ++trial) {
    Eigen::Vector3d u(std::normal_distribution<double>()(rng),
                      std::normal_distribution<double>()(rng),
                      0.2 * std::normal_distribution<double>()(rng));
    u.normalize();
    const int n = caster.Cast(Eigen::Vector3d(0.01, 0.02, 0.7), u, 4.0, &ray);
    const std::vector<double> prior = RandomPriors(rng, n);
    const Reading z{ReadingKind::kReturn, std::uniform_real_distribution<double>(0.5, 2.0)(rng)};
    std::vector<double> p_full(prior), p_cut(prior);
    const ExactUpdateResult rf = ComputeExactPosteriors(full, z, ray.distance_m.data(),
                                                        prior.data(), n, p_full.data(), &scratch);
    const ExactUpdateResult rc = ComputeExactPosteriors(cut, z, ray.distance_m.data(), prior.data(),
                                                        n, p_cut.data(), &scratch);
    ASSERT_EQ(rf.count, n);
    cells_left_out += n - rc.count;
    double eps = 0.0;
    for (int k = 0; k < n; ++k) {
      const double af = full.ReturnLikelihood(z.z_m, ray.distance_m[k]);
      const double ac = cut.ReturnLikelihood(z.z_m, ray.distance_m[k]);
      eps = std::max(eps, std::abs(af - ac) / af);
    }
    worst_eps = std::max(worst_eps, eps);
    for (int k = 0; k < n; ++k) {
      ASSERT_LE(std::abs(p_cut[k] - p_full[k]), p_full[k] * 2.0 * eps / (1.0 - eps) + 1e-15)
          << "k = " << k;
    }
  }
  EXPECT_GT(cells_left_out, 0);  // the shortcut really left cells out
  EXPECT_LT(worst_eps, 1e-3);
}

// The work per ray is linear in n_r: two passes, exactly one visit per cell in each, for rays of
// 10 to 10^4 cells (an O(n_r^2) loop would visit n_r^2 / 2).
TEST(InverseSensorModel, WorkIsLinearInRayLength) {
  const SensorModel model(SensorModelConfig::PaperXtion());
  for (int n : {10, 100, 1000, 10000}) {
    InverseSensorModelScratch scratch(n);
    std::vector<double> d(n), prior(n, 0.1), posterior(n);
    for (int k = 0; k < n; ++k) d[k] = 0.5 + 3.49 * k / n;  // all in range, none left out
    const Reading none{ReadingKind::kNoReturn, 0.0};
    ComputeExactPosteriors(model, none, d.data(), prior.data(), n, posterior.data(), &scratch);
    EXPECT_EQ(scratch.cell_visits(), 2u * static_cast<uint64_t>(n));
  }
}

// Multi-sensor fusion: the same return at a cell's distance, from the same prior, moves that
// cell further with the Hokuyo (sigma 0.1 m) than with the Xtion (sigma 0.25 m).
TEST(InverseSensorModel, SharperSensorMovesCellFurther) {
  const SensorModel xtion(SensorModelConfig::PaperXtion());
  const SensorModel hokuyo(SensorModelConfig::PaperHokuyo());
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  RayCells ray(4.0, g.resolution_m());
  const int n =
      RayCaster(g).Cast(Eigen::Vector3d(-3.0, 0.01, 0.7), Eigen::Vector3d::UnitX(), 4.0, &ray);
  const int hit = 30;  // ~2.2 m away
  const Reading z{ReadingKind::kReturn, ray.distance_m[hit]};
  InverseSensorModelScratch scratch(n);
  std::vector<double> prior(n, 0.1), px(n), ph(n);
  ComputeExactPosteriors(xtion, z, ray.distance_m.data(), prior.data(), n, px.data(), &scratch);
  ComputeExactPosteriors(hokuyo, z, ray.distance_m.data(), prior.data(), n, ph.data(), &scratch);
  EXPECT_GT(px[hit], 0.1);
  EXPECT_GT(ph[hit], px[hit]);
  // And a cell well in front of the return is cleared further by the sharper sensor too.
  EXPECT_LT(ph[hit - 10], px[hit - 10]);
}

// No phantom obstacles: 10^4 "no return" readings (clamped after each, as the map does) leave a
// cell nearer than z_min at or below its prior, and clear the cells in range.
TEST(InverseSensorModel, NoReturnNeverGrowsNearObstacles) {
  const SensorModel model(SensorModelConfig::PaperXtion());
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  RayCells ray(4.0, g.resolution_m());
  const int n =
      RayCaster(g).Cast(Eigen::Vector3d(-3.0, 0.01, 0.7), Eigen::Vector3d::UnitX(), 4.0, &ray);
  InverseSensorModelScratch scratch(n);
  std::vector<double> p(n, 0.1), posterior(n);
  for (int i = 0; i < 10000; ++i) {
    const ExactUpdateResult r =
        ComputeExactPosteriors(model, Reading{ReadingKind::kNoReturn, 0.0}, ray.distance_m.data(),
                               p.data(), n, posterior.data(), &scratch);
    for (int k = r.first; k < r.first + r.count; ++k) p[k] = ClampProbability(posterior[k], kPmin);
  }
  for (int k = 0; k < n; ++k) {
    if (ray.distance_m[k] < 0.5) {
      EXPECT_LE(p[k], 0.1) << "near cell " << k;
    } else {
      EXPECT_LT(p[k], 0.01) << "cell in range " << k;
    }
  }
}

TEST(InverseSensorModel, RejectsInvalidReading) {
  const SensorModel model(SensorModelConfig::PaperXtion());
  InverseSensorModelScratch scratch(4);
  const double d = 1.0, prior = 0.1;
  double post = 0.0;
  EXPECT_THROW(ComputeExactPosteriors(model, Reading{}, &d, &prior, 1, &post, &scratch),
               std::invalid_argument);
}

TEST(SensorModel, ValidateAndClassify) {
  SensorModelConfig config;
  config.cutoff_sigmas = 4.0;
  EXPECT_THROW(config.Validate(), std::invalid_argument);
  config = SensorModelConfig{};
  config.z_max_m = 0.4;
  EXPECT_THROW(config.Validate(), std::invalid_argument);
  const SensorModel model(SensorModelConfig::PaperHokuyo());
  EXPECT_EQ(model.Classify(std::nan("")).kind, ReadingKind::kInvalid);
  EXPECT_EQ(model.Classify(0.3).kind, ReadingKind::kInvalid);
  EXPECT_EQ(model.Classify(-1.0).kind, ReadingKind::kInvalid);
  EXPECT_EQ(model.Classify(0.5).kind, ReadingKind::kReturn);
  EXPECT_EQ(model.Classify(4.0).kind, ReadingKind::kNoReturn);
  EXPECT_EQ(model.Classify(std::numeric_limits<double>::infinity()).kind, ReadingKind::kNoReturn);
}

// The interpolated Gaussian (default) against direct exp/erfc evaluation of the same model:
// relative error of a_k below 1e-10 over a dense sweep of returns z and cell distances d, for
// both paper sensors (sensor_model.h documents this bound).
TEST(SensorModel, InterpolatedGaussianMatchesDirectEvaluation) {
  for (SensorModelConfig config :
       {SensorModelConfig::PaperXtion(), SensorModelConfig::PaperHokuyo()}) {
    const SensorModel table(config);
    config.interpolated_gaussian = false;
    const SensorModel direct(config);
    double worst = 0.0;
    std::mt19937 rng(21);
    std::uniform_real_distribution<double> zd(0.5, 4.0);
    for (int i = 0; i < 200000; ++i) {
      const double z = zd(rng);
      const double d = i % 2 ? zd(rng) : z + std::uniform_real_distribution<double>(-1.3, 1.3)(rng);
      const double a = direct.ReturnLikelihood(z, d);
      worst = std::max(worst, std::abs(table.ReturnLikelihood(z, d) - a) / a);
    }
    EXPECT_LT(worst, 1e-10) << "sigma " << config.sigma_m;
    EXPECT_GT(worst, 0.0);  // the tables really are in use
  }
}

// FillLikelihoods (eight rays at once) gives ReturnLikelihood / NoReturnProbability bit for bit:
// random returns and distances, and distances on and next to the edges (z_min, z_max, the
// window's z -+ c sigma, z itself), with "no return", invalid and unused lanes mixed in. Where
// the instruction set has no such kernel it says so and fills nothing.
TEST(SensorModel, BatchLikelihoodsEqualTheModelBitForBit) {
  constexpr int kL = lanes::kLanes;
  for (const SensorModelConfig& config :
       {SensorModelConfig::PaperXtion(), SensorModelConfig::PaperHokuyo()}) {
    const SensorModel model(config);
    const double cutoff = config.cutoff_sigmas * config.sigma_m;
    std::mt19937 rng(33);
    std::uniform_real_distribution<double> range(config.z_min_m, config.z_max_m);
    for (const kernels::Kernels* isa : kernels::Supported()) {
      SCOPED_TRACE(isa->name);
      int filled = 0;
      for (int batch = 0; batch < 400; ++batch) {
        const int count = 1 + batch % kL;
        Reading readings[kL];
        for (int l = 0; l < count; ++l) {
          const int kind = static_cast<int>(rng() % 8);
          readings[l] = kind == 0   ? Reading{ReadingKind::kNoReturn, 0.0}
                        : kind == 1 ? Reading{ReadingKind::kInvalid, 0.0}
                                    : Reading{ReadingKind::kReturn, range(rng)};
          // Some returns with a range band (docs/algorithms.md §3.8).
          if (kind >= 5) readings[l].below_m = std::uniform_real_distribution<double>(0, 1.5)(rng);
          readings[l].surface_unknown = kind == 7;  // a_k is read only before its band
        }
        constexpr int kRows = 40;
        std::vector<double> d(kRows * kL), a(kRows * kL, -1.0);
        for (int k = 0; k < kRows; ++k) {
          for (int l = 0; l < kL; ++l) {
            const double z = readings[l].z_m;
            const double lo = z - readings[l].below_m;
            const double edges[] = {config.z_min_m, config.z_max_m, lo - cutoff, z + cutoff, z, lo};
            double v = std::uniform_real_distribution<double>(0.0, config.z_max_m + 0.5)(rng);
            if (rng() % 3 == 0) {
              v = edges[rng() % 6];
              const int ulps = static_cast<int>(rng() % 3) - 1;  // on it, or one ulp either side
              if (ulps != 0) v = std::nextafter(v, ulps > 0 ? 1e9 : -1e9);
            }
            d[k * kL + l] = std::max(v, 0.0);
          }
        }
        if (!model.FillLikelihoods(readings, count, d.data(), kRows, a.data(), *isa)) continue;
        ++filled;
        for (int k = 0; k < kRows; ++k) {
          for (int l = 0; l < count; ++l) {
            const double dk = d[k * kL + l];
            const Reading& r = readings[l];
            if (r.surface_unknown && r.kind == ReadingKind::kReturn && !(dk < r.z_m - r.below_m))
              continue;
            const double expected = readings[l].kind == ReadingKind::kReturn
                                        ? model.ReturnLikelihood(readings[l], dk)
                                        : model.NoReturnProbability(dk);
            ASSERT_EQ(a[k * kL + l], expected)
                << "lane " << l << " z = " << readings[l].z_m << " d = " << dk;
          }
        }
      }
      // The vector kernels always fill (tables on); the scalar kernels leave a_k to the update.
      EXPECT_EQ(filled > 0, isa->target != 0);
    }
  }
}

// Each case of the forward model integrates to 1 over returns plus "no return" (numerical
// quadrature of the return density over [z_min, z_max)).
TEST(SensorModel, LikelihoodIntegratesToOne) {
  SensorModelConfig config = SensorModelConfig::PaperHokuyo();
  config.cutoff_sigmas = std::numeric_limits<double>::infinity();
  const SensorModel model(config);
  for (double d : {0.2, 0.5, 0.6, 2.0, 3.95, 4.5}) {
    const int steps = 200000;
    const double h = 3.5 / steps;
    double integral = 0.0;
    for (int i = 0; i < steps; ++i) integral += model.ReturnLikelihood(0.5 + (i + 0.5) * h, d) * h;
    EXPECT_NEAR(integral + model.NoReturnProbability(d), 1.0, 1e-6) << "d = " << d;
  }
}

}  // namespace
}  // namespace kestrel
