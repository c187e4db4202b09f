#include "exploration/information_gain.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include "exploration/ray_caster_2d.h"
#include "mapping/grid.h"
#include "mapping/occupancy_updater.h"
#include "mapping/range_bands.h"
#include "mapping/ray_caster.h"

namespace kestrel {
namespace {

// A real 2D ray: cast from `origin` at `angle` through a grid of edge alpha.
Ray2D CastIn(const GridMap2D& g, const Eigen::Vector2d& origin, double angle, double length) {
  Ray2D ray;
  CastRay2D(g, origin, Eigen::Vector2d(std::cos(angle), std::sin(angle)), length, &ray);
  return ray;
}

// A 4 m ray from a random origin at a random angle through an 8 x 12 m grid of edge alpha (the
// origin's x, y, then the angle drawn from rng, in that order).
Ray2D RandomRay(std::mt19937& rng, double alpha) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const GridMap2D g =
      GridMap2D::Filled({-4.0, -6.0}, alpha, 0.75, static_cast<int>(std::ceil(8.0 / alpha)),
                        static_cast<int>(std::ceil(12.0 / alpha)), 0.1);
  const Eigen::Vector2d o(-4.0 + 8.0 * u(rng), -6.0 + 12.0 * u(rng));
  return CastIn(g, o, 2.0 * M_PI * u(rng), 4.0);
}

// Priors as the projected maps produce them: unknown, well-known (P_min_E, 1 - P_min_E), any.
std::vector<double> RandomPriors(std::mt19937& rng, int n) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> p(static_cast<size_t>(n));
  for (double& v : p) {
    const double r = u(rng);
    v = r < 0.3 ? 0.1 : r < 0.5 ? 0.01 : r < 0.6 ? 0.99 : r < 0.65 ? 0.5 : r < 0.7 ? 1e-4 : u(rng);
  }
  return p;
}

RayEntropy Evaluate(const SensorModel& m, const Ray2D& ray, const std::vector<double>& prior,
                    WeightMode mode, GainMethod method, ExpectedEntropyTerms* terms = nullptr) {
  ExpectedEntropyScratch scratch;
  return ExpectedEntropy::Compute(m, ray.entry_m.data(), ray.exit_m.data(), ray.distance_m.data(),
                                  prior.data(), ray.size, mode, method, &scratch, terms);
}

// docs/algorithms.md §6.4: the fast evaluation equals the direct (n+1)^2 one to 1e-9 relative on
// random rays (both sensors, both weightings, E-sized and B-sized cells, rays that leave the map).
TEST(InformationGain, FastEqualsDirect) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  SensorModelConfig exact_gauss = SensorModelConfig::Hokuyo();
  exact_gauss.interpolated_gaussian = false;
  const std::vector<SensorModel> models{SensorModel(SensorModelConfig::Xtion()),
                                        SensorModel(SensorModelConfig::Hokuyo()),
                                        SensorModel(exact_gauss)};
  int compared = 0;
  for (int trial = 0; trial < 600; ++trial) {
    const double alpha = trial % 3 == 0 ? 0.9 : (trial % 3 == 1 ? 0.075 : 0.3);
    const Ray2D ray = RandomRay(rng, alpha);
    const std::vector<double> prior = RandomPriors(rng, ray.size);
    const SensorModel& m = models[static_cast<size_t>(trial) % models.size()];
    for (WeightMode mode : {WeightMode::kChordProbability, WeightMode::kPaperLiteral}) {
      const RayEntropy d = Evaluate(m, ray, prior, mode, GainMethod::kDirect);
      const RayEntropy f = Evaluate(m, ray, prior, mode, GainMethod::kFast);
      ASSERT_NEAR(f.prior_entropy_nats, d.prior_entropy_nats,
                  1e-12 * d.prior_entropy_nats + 1e-300);
      ASSERT_NEAR(f.expected_entropy_nats, d.expected_entropy_nats, 1e-9 * d.expected_entropy_nats)
          << "trial " << trial << " n " << ray.size;
      ASSERT_NEAR(f.gain_nats(), d.gain_nats(), 1e-9 * std::max(d.prior_entropy_nats, 1e-3))
          << "trial " << trial;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 1200);
}

// Predicted range bands (docs/algorithms.md §3.8, "Predicted bands"): the fast evaluation with
// its kernel's banded hypotheses equals the direct one, which calls the mapper's exact update
// with each hypothesis's banded reading; for a whole ray and for prefixes of its kernel.
TEST(InformationGain, PredictedBandsFastEqualsDirect) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<SensorModel> models;
  for (const double surface_max : {std::numeric_limits<double>::infinity(), 0.1}) {
    for (SensorModelConfig c : {SensorModelConfig::Xtion(), SensorModelConfig::Hokuyo()}) {
      c.direction_uncertainty_rad = 0.0175;
      c.band_surface_max_m = surface_max;
      models.emplace_back(c);
    }
  }
  int banded = 0, unknown_surface = 0, compared = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const double alpha = trial % 2 == 0 ? 0.075 : 0.3;
    const Ray2D ray = RandomRay(rng, alpha);
    const std::vector<double> prior = RandomPriors(rng, ray.size);
    std::vector<double> incidence(static_cast<size_t>(ray.size));
    for (double& c : incidence) c = u(rng) < 0.3 ? 1.0 : u(rng);
    const SensorModel& m = models[static_cast<size_t>(trial) % models.size()];
    for (int k = 0; k < ray.size; ++k) {
      const Reading r = PredictedBandedReturn(m.config(), ray.distance_m[static_cast<size_t>(k)],
                                              incidence[static_cast<size_t>(k)]);
      banded += r.has_band() ? 1 : 0;
      unknown_surface += r.surface_unknown ? 1 : 0;
    }
    RayKernel kernel;
    kernel.Build(m, ray.entry_m.data(), ray.exit_m.data(), ray.distance_m.data(), ray.size,
                 incidence.data());
    for (WeightMode mode : {WeightMode::kChordProbability, WeightMode::kPaperLiteral}) {
      for (const int n : {ray.size, ray.size / 2}) {
        ExpectedEntropyScratch scratch;
        const RayEntropy d = ExpectedEntropy::Compute(
            m, ray.entry_m.data(), ray.exit_m.data(), ray.distance_m.data(), prior.data(), n, mode,
            GainMethod::kDirect, &scratch, nullptr, incidence.data());
        const RayEntropy f = ExpectedEntropy::Evaluate(m, kernel, prior.data(), n, mode, &scratch);
        ASSERT_NEAR(f.expected_entropy_nats, d.expected_entropy_nats,
                    1e-9 * d.expected_entropy_nats + 1e-300)
            << "trial " << trial << " n " << n;
        ++compared;
      }
    }
  }
  EXPECT_EQ(compared, 1600);
  EXPECT_GT(banded, 1000);  // the bands were exercised, surface_unknown ones among them
  EXPECT_GT(unknown_surface, 100);
}

// At normal incidence the predicted band is empty: the plain gain, bit for bit. At grazing
// incidence the gain is another: the cells of each hypothesis's band keep their prior (here
// unknown cells, p_init 0.1, whose entropy a plain return would raise at the surface and lower
// before it). The kernel is matched only with the same incidences.
TEST(InformationGain, PredictedBandsChangeTheGainOnlyAtGrazingIncidence) {
  SensorModelConfig c = SensorModelConfig::Xtion();
  const SensorModel plain(c);
  c.direction_uncertainty_rad = 0.0175;
  c.band_surface_max_m = 0.1;
  const SensorModel bands(c);
  const GridMap2D g = GridMap2D::Filled({-1.0, -1.0}, 0.075, 0.75, 80, 80, 0.1);
  const Ray2D ray = CastIn(g, {0.0, 0.0}, 0.3, 4.0);
  const std::vector<double> prior(static_cast<size_t>(ray.size), 0.1);  // unknown (p_init)
  const std::vector<double> normal(static_cast<size_t>(ray.size), 1.0);
  const std::vector<double> grazing(static_cast<size_t>(ray.size), 0.15);
  const auto gain = [&](const SensorModel& m, const std::vector<double>* incidence) {
    ExpectedEntropyScratch scratch;
    return ExpectedEntropy::Compute(m, ray.entry_m.data(), ray.exit_m.data(), ray.distance_m.data(),
                                    prior.data(), ray.size, WeightMode::kChordProbability,
                                    GainMethod::kFast, &scratch, nullptr,
                                    incidence == nullptr ? nullptr : incidence->data())
        .gain_nats();
  };
  const double plain_gain = gain(plain, nullptr);
  EXPECT_EQ(gain(bands, &normal), plain_gain);
  EXPECT_EQ(gain(bands, nullptr), plain_gain);  // no incidences: no bands predicted
  EXPECT_GT(std::abs(gain(bands, &grazing) - plain_gain), 0.2 * plain_gain);
  RayKernel kernel;
  kernel.Build(bands, ray.entry_m.data(), ray.exit_m.data(), ray.distance_m.data(), ray.size,
               normal.data());
  EXPECT_TRUE(kernel.Matches(ray.entry_m.data(), ray.exit_m.data(), ray.distance_m.data(), ray.size,
                             normal.data()));
  EXPECT_FALSE(kernel.Matches(ray.entry_m.data(), ray.exit_m.data(), ray.distance_m.data(),
                              ray.size, grazing.data()));
  EXPECT_FALSE(kernel.Matches(ray.entry_m.data(), ray.exit_m.data(), ray.distance_m.data(),
                              ray.size, nullptr));
}

// EntropySum::kLanes (AVX-512 where the CPU has it, else the scalar sum) equals kScalar to
// ~1e-15 relative on random rays: its log is accurate to a few ulp and only the order of the
// sums differs. Also over priors down to 1e-300 and up to 1 - 1e-16.
TEST(InformationGain, LaneEntropySumsEqualScalar) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const std::vector<SensorModel> models{SensorModel(SensorModelConfig::Xtion()),
                                        SensorModel(SensorModelConfig::Hokuyo())};
  double worst = 0.0;
  for (int trial = 0; trial < 400; ++trial) {
    const double alpha = trial % 2 == 0 ? 0.075 : 0.3;
    const Ray2D ray = RandomRay(rng, alpha);
    std::vector<double> prior = RandomPriors(rng, ray.size);
    if (trial % 5 == 0) {
      for (double& p : prior) p = u(rng) < 0.5 ? std::pow(10.0, -300.0 * u(rng)) : 1.0 - 1e-16;
    }
    const SensorModel& m = models[static_cast<size_t>(trial) % models.size()];
    RayKernel kernel;
    kernel.Build(m, ray.entry_m.data(), ray.exit_m.data(), ray.distance_m.data(), ray.size);
    for (WeightMode mode : {WeightMode::kChordProbability, WeightMode::kPaperLiteral}) {
      ExpectedEntropyScratch scratch;
      const RayEntropy a = ExpectedEntropy::Evaluate(m, kernel, prior.data(), ray.size, mode,
                                                     &scratch, EntropySum::kScalar);
      const RayEntropy b = ExpectedEntropy::Evaluate(m, kernel, prior.data(), ray.size, mode,
                                                     &scratch, EntropySum::kLanes);
      EXPECT_NEAR(a.prior_entropy_nats, b.prior_entropy_nats, 1e-14 * a.prior_entropy_nats);
      const double err = std::abs(a.expected_entropy_nats - b.expected_entropy_nats) /
                         std::max(a.expected_entropy_nats, 1e-300);
      worst = std::max(worst, err);
      ASSERT_LE(err, 1e-13) << "trial " << trial;
    }
  }
  std::printf("lane entropy sums: worst relative difference %.3g\n", worst);
}

// Section 6 weights: the q_k of a ray that reaches z_max inside the map, plus P(no return), sum
// to 1 up to the Gaussian mass outside the model's 5-sigma window (< 5.7e-7).
TEST(InformationGain, ChordWeightsSumToOne) {
  std::mt19937 rng(5);
  const GridMap2D g = GridMap2D::Filled({-10.0, -10.0}, 0.075, 0.75, 267, 267, 0.1);
  for (const SensorModelConfig& c : {SensorModelConfig::Xtion(), SensorModelConfig::Hokuyo()}) {
    const SensorModel m(c);
    for (int trial = 0; trial < 20; ++trial) {
      const Ray2D ray = CastIn(g, {0.01 * trial, 0.02}, 0.3 * trial, c.z_max_m);
      ASSERT_FALSE(ray.left_bounds);
      const std::vector<double> prior = RandomPriors(rng, ray.size);
      ExpectedEntropyTerms terms;
      Evaluate(m, ray, prior, WeightMode::kChordProbability, GainMethod::kDirect, &terms);
      double sum = 0.0;
      for (double q : terms.weight_unnormalised) sum += q;
      EXPECT_NEAR(sum, 1.0, 6e-7);
      EXPECT_LE(sum, 1.0 + 1e-12);
      for (int k = 0; k < ray.size; ++k) {
        if (ray.exit_m[static_cast<size_t>(k)] <= c.z_min_m) {
          EXPECT_EQ(terms.weight_unnormalised[static_cast<size_t>(k)], 0.0);
        }
      }
    }
  }
}

// The paper's literal eq. (8): weights are 1/eta_k = p(z_k), checked against a brute-force sum
// over all 2^n occupancy patterns of a short ray; "no return" gets P(no return).
TEST(InformationGain, LiteralWeightsAreMeasurementLikelihoods) {
  const SensorModel m(SensorModelConfig::Xtion());
  const GridMap2D g = GridMap2D::Filled({0.0, 0.0}, 0.3, 0.75, 30, 30, 0.1);
  const Ray2D ray = CastIn(g, {4.5, 4.5}, 0.0, 4.0);
  ASSERT_LE(ray.size, 16);
  std::mt19937 rng(9);
  const std::vector<double> prior = RandomPriors(rng, ray.size);
  ExpectedEntropyTerms terms;
  Evaluate(m, ray, prior, WeightMode::kPaperLiteral, GainMethod::kDirect, &terms);
  const int n = ray.size;
  for (int k = 0; k <= n; ++k) {
    const double z = terms.hypothesis_z_m[static_cast<size_t>(k)];
    if (k < n && std::isnan(z)) continue;
    double p = 0.0;
    for (uint32_t pattern = 0; pattern < (1u << n); ++pattern) {
      double w = 1.0;
      int first = -1;
      for (int j = 0; j < n; ++j) {
        const bool occ = (pattern >> j) & 1u;
        w *= occ ? prior[static_cast<size_t>(j)] : 1.0 - prior[static_cast<size_t>(j)];
        if (occ && first < 0) first = j;
      }
      const double d = first < 0 ? 1e9 : ray.distance_m[static_cast<size_t>(first)];
      p += w * (k < n ? m.ReturnLikelihood(z, d) : m.NoReturnProbability(d));
    }
    EXPECT_NEAR(terms.weight_unnormalised[static_cast<size_t>(k)], p, 1e-12 * p) << k;
  }
}

// Monte Carlo check of eq. (7): sample maps from the prior, a measurement from the
// forward model, snap it to the cell whose chord contains it (the discretisation behind the
// weights) and average the posterior entropy H_k. Sampling error: 4 standard errors of the mean
// (the test states it); discretisation error: zero for the snapped estimator by construction,
// and the unsnapped (posterior at the sampled z) difference is printed for information.
TEST(InformationGain, ExpectedEntropyMatchesMonteCarlo) {
  struct Case {
    SensorModelConfig sensor;
    double alpha;
    double angle;
  };
  for (const Case& cs :
       {Case{SensorModelConfig::Xtion(), 0.3, 0.2}, Case{SensorModelConfig::Hokuyo(), 0.075, 0.7},
        Case{SensorModelConfig::Xtion(), 0.9, 0.0}}) {
    const SensorModel m(cs.sensor);
    const SensorModelConfig& c = cs.sensor;
    const GridMap2D g = GridMap2D::Filled({0.0, 0.0}, cs.alpha, 0.75, 60, 60, 0.1);
    const Ray2D ray = CastIn(g, {0.5 * cs.alpha, 0.5 * cs.alpha}, cs.angle, c.z_max_m);
    const int n = ray.size;
    // A plausible ray: free near the sensor, unknown, a likely wall at about 2.6 m.
    std::vector<double> prior(static_cast<size_t>(n), 0.1);
    for (int j = 0; j < n; ++j) {
      const double d = ray.distance_m[static_cast<size_t>(j)];
      if (d < 1.2) prior[static_cast<size_t>(j)] = 0.02;
      if (d > 2.5 && d < 2.9) prior[static_cast<size_t>(j)] = 0.6;
      if (d > 3.3) prior[static_cast<size_t>(j)] = 0.3;
    }
    ExpectedEntropyTerms terms;
    const RayEntropy exact =
        Evaluate(m, ray, prior, WeightMode::kChordProbability, GainMethod::kDirect, &terms);
    std::mt19937_64 rng(12345);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::normal_distribution<double> gauss(0.0, c.sigma_m);
    const int samples = 200000;
    double sum = 0.0, sum2 = 0.0, sum_cont = 0.0;
    int accepted = 0;
    InverseSensorModelScratch isms(n + 4);
    std::vector<double> post(static_cast<size_t>(n));
    for (int s = 0; s < samples; ++s) {
      int first = -1;
      for (int j = 0; j < n && first < 0; ++j) {
        if (u(rng) < prior[static_cast<size_t>(j)]) first = j;
      }
      bool none = false;
      double z = 0.0;
      const double d = first < 0 ? 0.0 : ray.distance_m[static_cast<size_t>(first)];
      const bool in_range = first >= 0 && d >= c.z_min_m && d < c.z_max_m;
      if (u(rng) < c.p_rand) {
        z = c.z_min_m + (c.z_max_m - c.z_min_m) * u(rng);
      } else if (in_range && u(rng) >= c.p_miss) {
        do {
          z = d + gauss(rng);
        } while (
            !(z >= c.z_min_m && z < c.z_max_m && std::abs(z - d) <= c.cutoff_sigmas * c.sigma_m));
      } else {
        none = true;
      }
      int k = n;
      if (!none) {
        k = -1;
        for (int j = 0; j < n; ++j) {
          if (z >= ray.entry_m[static_cast<size_t>(j)] && z < ray.exit_m[static_cast<size_t>(j)]) {
            k = j;
          }
        }
        if (k < 0) continue;  // beyond the ray's last chord: not a hypothesis
      }
      const double h = terms.posterior_entropy_nats[static_cast<size_t>(k)];
      sum += h;
      sum2 += h * h;
      ++accepted;
      // Unsnapped: the posterior at the sampled z itself (for the stated discretisation error).
      const Reading reading =
          none ? Reading{ReadingKind::kNoReturn, 0.0} : Reading{ReadingKind::kReturn, z};
      const ExactUpdateResult r = ComputeExactPosteriors(m, reading, ray.distance_m.data(),
                                                         prior.data(), n, post.data(), &isms);
      double hc = 0.0;
      for (int j = 0; j < n; ++j) {
        const bool written = j >= r.first && j < r.first + r.count;
        hc += BinaryEntropy(written ? post[static_cast<size_t>(j)] : prior[static_cast<size_t>(j)]);
      }
      sum_cont += hc;
    }
    const double mean = sum / accepted;
    const double var = sum2 / accepted - mean * mean;
    const double se = std::sqrt(var / accepted);
    std::printf(
        "alpha %.3f sigma %.2f n %d: E[H] %.6f, MC %.6f +- %.6f (1 SE), unsnapped MC %.6f "
        "(discretisation %.2e), prior %.6f\n",
        cs.alpha, c.sigma_m, n, exact.expected_entropy_nats, mean, se, sum_cont / accepted,
        sum_cont / accepted - mean, exact.prior_entropy_nats);
    EXPECT_NEAR(mean, exact.expected_entropy_nats, 4.0 * se + 1e-6);
    EXPECT_GT(exact.gain_nats(), 0.0);
  }
}

// A ray whose cells are all certain (0 or 1) has nothing to learn; an unknown ray has gain.
TEST(InformationGain, CertainRayHasNoGain) {
  const SensorModel m(SensorModelConfig::Xtion());
  const GridMap2D g = GridMap2D::Filled({0.0, 0.0}, 0.075, 0.75, 100, 100, 0.1);
  const Ray2D ray = CastIn(g, {3.0, 3.0}, 1.0, 4.0);
  std::vector<double> prior(static_cast<size_t>(ray.size), 0.0);
  prior[30] = 1.0;
  for (GainMethod method : {GainMethod::kDirect, GainMethod::kFast}) {
    const RayEntropy r = Evaluate(m, ray, prior, WeightMode::kChordProbability, method);
    EXPECT_EQ(r.prior_entropy_nats, 0.0);
    EXPECT_NEAR(r.expected_entropy_nats, 0.0, 1e-12);
    std::vector<double> unknown(static_cast<size_t>(ray.size), 0.1);
    EXPECT_GT(Evaluate(m, ray, unknown, WeightMode::kChordProbability, method).gain_nats(), 0.1);
  }
}

// The 2D caster lists the same cells and distances as mapping's 3D caster on a one-layer grid.
TEST(RayCaster2D, MatchesMappingCasterOnOneLayer) {
  MapLimits limits;
  limits.min_m = {-4.0, -6.0, 0.0};
  limits.max_m = {4.0, 6.0, 0.075};
  limits.resolution_m = 0.075;
  const GridGeometry geo = GridGeometry::Fixed(limits);
  const RayCaster caster(geo);
  RayCells cells3(5.0, 0.075);
  const GridMap2D g = GridMap2D::Filled({-4.0, -6.0}, 0.075, 0.0375, 107, 160, 0.1);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 2000; ++trial) {
    Eigen::Vector2d o(-4.0 + 8.0 * u(rng), -6.0 + 12.0 * u(rng));
    if (trial % 4 == 0) o = g.CenterOf({static_cast<int>(u(rng) * 100), 5});    // cell centres
    if (trial % 4 == 1) o.x() = -4.0 + 0.075 * static_cast<int>(u(rng) * 100);  // on a boundary
    double angle = 2.0 * M_PI * u(rng);
    if (trial % 8 == 2) angle = M_PI / 4 * static_cast<int>(u(rng) * 8);  // axes, diagonals
    Eigen::Vector2d dir(std::cos(angle), std::sin(angle));
    for (int a = 0; a < 2; ++a) {
      if (std::abs(dir[a]) < 1e-15) dir[a] = 0.0;
    }
    dir.normalize();
    Ray2D ray;
    CastRay2D(g, o, dir, 4.0, &ray);
    caster.Cast(Eigen::Vector3d(o.x(), o.y(), 0.0375), Eigen::Vector3d(dir.x(), dir.y(), 0.0), 4.0,
                &cells3);
    ASSERT_EQ(ray.size, cells3.size) << trial;
    for (int k = 0; k < ray.size; ++k) {
      const CellIndex& c = cells3.cells[static_cast<size_t>(k)];
      ASSERT_EQ(ray.index[static_cast<size_t>(k)], g.IndexOf(c.x, c.y)) << trial << " " << k;
      ASSERT_NEAR(ray.distance_m[static_cast<size_t>(k)], cells3.distance_m[static_cast<size_t>(k)],
                  1e-12);
    }
    // Chords tile [0, L] (or up to the bounds) without gaps.
    for (int k = 1; k < ray.size; ++k) {
      ASSERT_EQ(ray.entry_m[static_cast<size_t>(k)], ray.exit_m[static_cast<size_t>(k - 1)]);
    }
  }
}

// Kernels shared between positions (same chords, checked) give the direct (n+1)^2 gains to 1e-9
// relative, on E-sized and B-sized maps, at lattice positions (shared) and anywhere (rebuilt), with
// rays cut short by the map's bounds.
TEST(GainEvaluator, SharedKernelsEqualDirect) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (double alpha : {0.075, 0.9}) {
    GridMap2D g =
        GridMap2D::Filled({-4.0, -6.0}, alpha, 0.75, static_cast<int>(std::ceil(8.0 / alpha)),
                          static_cast<int>(std::ceil(12.0 / alpha)), 0.1);
    for (double& v : g.values) {
      const double r = u(rng);
      v = r < 0.4 ? 0.01 : r < 0.7 ? 0.1 : r < 0.8 ? 0.99 : u(rng);
    }
    GainConfig fast_config;
    GainConfig direct_config;
    direct_config.method = GainMethod::kDirect;
    GainEvaluator fast(fast_config), direct(direct_config);
    for (int trial = 0; trial < 12; ++trial) {
      // Lattice points of a 0.9 m collision grid (12 E cells), then arbitrary points.
      const Eigen::Vector2d p = trial < 8
                                    ? Eigen::Vector2d(-4.0 + 0.9 * (trial % 4) + 0.45,
                                                      -6.0 + 0.9 * (3 * (trial / 4) + 1) + 0.45)
                                    : Eigen::Vector2d(-4.0 + 8.0 * u(rng), -6.0 + 12.0 * u(rng));
      const std::vector<double> a = fast.HeadingGains(g, p, 8);
      const std::vector<double> b = direct.HeadingGains(g, p, 8);
      for (int m = 0; m < 8; ++m) {
        ASSERT_NEAR(a[static_cast<size_t>(m)], b[static_cast<size_t>(m)],
                    1e-9 * std::abs(b[static_cast<size_t>(m)]) + 1e-9)
            << "alpha " << alpha << " trial " << trial << " heading " << m;
      }
    }
    // Sharing happened: far fewer kernels than rays.
    EXPECT_LT(fast.kernels_built(), 12 * 2 * 180);
  }
}

// Headings at one position share the ray evaluations exactly: HeadingGains equals PoseGain, and
// every sensor contributes the rays inside its field of view.
TEST(GainEvaluator, HeadingGainsEqualPoseGains) {
  GainConfig config;
  GainEvaluator eval(config);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  GridMap2D g = GridMap2D::Filled({-4.0, -6.0}, 0.3, 0.75, 27, 40, 0.1);
  for (double& v : g.values) v = u(rng) < 0.5 ? 0.01 : (u(rng) < 0.5 ? 0.1 : u(rng));
  GainStats stats;
  const std::vector<double> gains = eval.HeadingGains(g, {0.15, 0.45}, 8, 0.0, &stats);
  for (int m = 0; m < 8; ++m) {
    EXPECT_NEAR(gains[static_cast<size_t>(m)], eval.PoseGain(g, {0.15, 0.45}, M_PI / 4 * m),
                1e-12 * gains[static_cast<size_t>(m)]);
  }
  // 58 deg at 2 deg per ray: 29 or 30 rays; 240 deg: 121 rays.
  EXPECT_GE(stats.rays_per_pose, 150);
  EXPECT_LE(stats.rays_per_pose, 151);
  EXPECT_EQ(eval.RayIndices(1, 0.0).size(), 121u);
  EXPECT_LE(stats.rays_cast, 2 * 180);
}

// A planar scanner is credited against the layer it sees: E (whole columns) says unknown, the
// LIDAR's layer is known free, so with the layer the Hokuyo's rays predict almost nothing while
// the camera's are unchanged.
TEST(GainEvaluator, PlanarSensorUsesItsLayer) {
  GainConfig config;
  ASSERT_TRUE(config.sensors[1].planar);
  ASSERT_FALSE(config.sensors[0].planar);
  GainEvaluator eval(config);
  const GridMap2D e = GridMap2D::Filled({-4.0, -4.0}, 0.075, 0.75, 107, 107, 0.1);
  const GridMap2D layer = GridMap2D::Filled({-4.0, -4.0}, 0.075, 0.87, 107, 107, 1e-4);
  const std::vector<double> columns = eval.HeadingGains(e, {0.0, 0.0}, 4);
  const std::vector<double> seen =
      eval.HeadingGains(e, {0.0, 0.0}, 4, 0.0, nullptr, 0.0, nullptr, &layer);
  GainConfig camera_only = config;
  camera_only.sensors.resize(1);
  GainEvaluator camera(camera_only);
  const std::vector<double> camera_gains = camera.HeadingGains(e, {0.0, 0.0}, 4);
  for (int m = 0; m < 4; ++m) {
    const size_t i = static_cast<size_t>(m);
    EXPECT_GT(columns[i] - camera_gains[i], 10.0);  // the LIDAR on E's columns
    // On its free layer: at most the entropy of the clamp (1e-4) on its 121 rays of <= 54 cells.
    const double h_clamp = -1e-4 * std::log(1e-4) - (1 - 1e-4) * std::log(1 - 1e-4);
    EXPECT_GE(seen[i], camera_gains[i]);
    EXPECT_LT(seen[i] - camera_gains[i], 121 * 54 * h_clamp);
  }
}

}  // namespace
}  // namespace kestrel
