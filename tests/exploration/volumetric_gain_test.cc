#include "exploration/volumetric_gain.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "mapping/grid.h"
#include "mapping/occupancy_updater.h"
#include "mapping/ray_caster.h"

namespace kestrel {
namespace {

// A dense probability grid over [min, max) at edge alpha, every cell at `value`.
DenseGrid MakeGrid(const Eigen::Vector3d& min_m, const Eigen::Vector3d& max_m, double alpha,
                   float value) {
  MapLimits limits;
  limits.min_m = min_m;
  limits.max_m = max_m;
  limits.resolution_m = alpha;
  return DenseGrid(limits, value);
}

// Sets every cell whose centre satisfies `inside` to `value`.
void Fill(DenseGrid* grid, const std::function<bool(const Eigen::Vector3d&)>& inside, float value) {
  const CellIndex d = grid->dims();
  for (int k = 0; k < d.z; ++k) {
    for (int j = 0; j < d.y; ++j) {
      for (int i = 0; i < d.x; ++i) {
        const CellIndex c{i, j, k};
        if (inside(grid->geometry().CenterOf(c))) grid->Set(c, value);
      }
    }
  }
}

// The brute force: every ray built here from the documented convention (volumetric_gain.h),
// cast with mapping's RayCaster from position + (0, 0, height_offset), chords from the
// midpoints, E[H] by the direct (n+1)^2 method, per-heading sums over the documented windows.
struct Brute {
  std::vector<double> gain, bound;
};

Brute BruteForce(const DenseGrid& grid, const VolumetricGainConfig& config,
                 const Eigen::Vector3d& position, int n_yaw) {
  const RayCaster caster(grid.geometry());
  const int bins = config.azimuth_bins;
  const auto snap = [](double v) { return std::abs(v) < 1e-15 ? 0.0 : v; };
  Brute out;
  out.gain.assign(static_cast<size_t>(n_yaw), 0.0);
  out.bound.assign(static_cast<size_t>(n_yaw), 0.0);
  ExpectedEntropyScratch scratch;
  const Eigen::Vector3d box_min = grid.geometry().origin_m();
  const Eigen::Vector3d box_max =
      box_min +
      grid.geometry().resolution_m() * Eigen::Vector3d(grid.dims().x, grid.dims().y, grid.dims().z);
  for (const VolumetricSensor& s : config.sensors) {
    const SensorModel model(s.model);
    SensorModelConfig reported_config = s.model;
    reported_config.no_return_informs = true;
    const SensorModel reported_model(reported_config);
    RayCells cells(s.model.z_max_m, grid.geometry().resolution_m());
    std::vector<double> bin_gain(static_cast<size_t>(bins), 0.0);
    std::vector<double> bin_bound(static_cast<size_t>(bins), 0.0);
    const Eigen::Vector3d o = position + Eigen::Vector3d(0.0, 0.0, s.height_offset_m);
    for (int row = 0; row < s.rows; ++row) {
      const double el = s.vertical_fov_rad == 0.0
                            ? 0.0
                            : -0.5 * s.vertical_fov_rad + s.vertical_fov_rad * (row + 0.5) / s.rows;
      for (int b = 0; b < bins; ++b) {
        const double az = 2.0 * M_PI * b / bins;
        const Eigen::Vector3d u(snap(std::cos(el) * std::cos(az)),
                                snap(std::cos(el) * std::sin(az)), snap(std::sin(el)));
        const int n = caster.Cast(o, u, s.model.z_max_m, &cells);
        std::vector<double> entry(static_cast<size_t>(n)), exit(static_cast<size_t>(n)),
            prior(static_cast<size_t>(n));
        double e = 0.0;
        for (int k = 0; k < n; ++k) {
          const size_t at = static_cast<size_t>(k);
          entry[at] = e;
          exit[at] = 2.0 * cells.distance_m[at] - e;
          e = exit[at];
          prior[at] = static_cast<double>(grid.Get(cells.cells[at]));
        }
        if (n == 0) continue;
        // Predicted range bands: |cos| between the ray and the normal of each cell's entry face
        // (the axis whose index changed; the first cell enters through none).
        std::vector<double> incidence(static_cast<size_t>(n), 1.0);
        for (int k = 1; k < n; ++k) {
          const CellIndex& a = cells.cells[static_cast<size_t>(k - 1)];
          const CellIndex& c = cells.cells[static_cast<size_t>(k)];
          for (int axis = 0; axis < 3; ++axis) {
            if (a[axis] != c[axis]) incidence[static_cast<size_t>(k)] = std::abs(u[axis]);
          }
        }
        // A no-return is evidence where the ray's point at reports_to_m lies inside the box's
        // horizontal extent and not above its top (VolumetricSensor::reports_to_m).
        const Eigen::Vector3d end = o + s.reports_to_m * u;
        const bool reported = s.reports_to_m > 0.0 && end.x() >= box_min.x() &&
                              end.x() <= box_max.x() && end.y() >= box_min.y() &&
                              end.y() <= box_max.y() && end.z() <= box_max.z();
        const RayEntropy r = ExpectedEntropy::Compute(
            reported ? reported_model : model, entry.data(), exit.data(), cells.distance_m.data(),
            prior.data(), n, config.weight_mode, GainMethod::kDirect, &scratch, nullptr,
            s.model.direction_uncertainty_rad > 0.0 ? incidence.data() : nullptr);
        bin_gain[static_cast<size_t>(b)] += r.gain_nats();
        // The bound: the prior entropy, and with chord-probability weights at most ln(n + 1)
        // (H of the hypotheses; the evaluator's header).
        bin_bound[static_cast<size_t>(b)] +=
            config.weight_mode == WeightMode::kChordProbability
                ? std::min(r.prior_entropy_nats, std::log(static_cast<double>(n) + 1.0))
                : r.prior_entropy_nats;
      }
    }
    for (int m = 0; m < n_yaw; ++m) {
      const double centre = 2.0 * M_PI * m / n_yaw + s.yaw_offset_rad;
      for (int b = 0; b < bins; ++b) {
        // Angle from the window's centre to the bin, in [-pi, pi).
        double diff = std::remainder(2.0 * M_PI * b / bins - centre, 2.0 * M_PI);
        if (diff >= M_PI) diff -= 2.0 * M_PI;
        if (std::abs(diff) <= 0.5 * s.horizontal_fov_rad + 1e-9) {
          out.gain[static_cast<size_t>(m)] += bin_gain[static_cast<size_t>(b)];
          out.bound[static_cast<size_t>(m)] += bin_bound[static_cast<size_t>(b)];
        }
      }
    }
  }
  return out;
}

// A small map of random priors: unknown (0.1), near 0 / 1, anything.
DenseGrid RandomMap(unsigned seed) {
  DenseGrid grid = MakeGrid({-1.0, -2.0, 0.0}, {3.0, 2.0, 1.5}, 0.075, 0.1f);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (float& v : grid.mutable_values()) {
    const double r = u(rng);
    v = static_cast<float>(r < 0.35   ? 0.1
                           : r < 0.55 ? 1e-4
                           : r < 0.62 ? 0.9999
                           : r < 0.7  ? 0.01
                                      : 0.02 + 0.96 * u(rng));
  }
  return grid;
}

void ExpectGainsEqual(const PoseGains& got, const Brute& want, const std::string& what) {
  ASSERT_EQ(got.gain_nats.size(), want.gain.size()) << what;
  for (size_t m = 0; m < want.gain.size(); ++m) {
    EXPECT_NEAR(got.gain_nats[m], want.gain[m], 1e-9 * std::max(std::abs(want.gain[m]), 1e-3))
        << what << " heading " << m;
    EXPECT_NEAR(got.bound_nats[m], want.bound[m], 1e-9 * std::max(want.bound[m], 1e-3))
        << what << " heading " << m;
  }
}

// Every heading's gain equals the brute force (direct method, rays cast at the position) to
// 1e-9 relative: positions at cell centres (the templates: the second one in a row builds them)
// and at arbitrary offsets (cast per position), with templates (and the lanes' entropy sums)
// and without (scalar sums), both weightings; with `bands`, the sensors' predicted range bands
// (docs/algorithms.md §3.8, "Predicted bands"). `gains` gets the gains, heading by heading.
void CheckEqualsBruteForce(bool bands, std::vector<double>* gains) {
  const DenseGrid grid = RandomMap(7);
  const OccupancyGridView view = ViewOf(grid);
  const GridGeometry& g = grid.geometry();
  const auto centre = [&](int i, int j, int k) { return g.CenterOf(CellIndex{i, j, k}); };
  const std::vector<Eigen::Vector3d> positions{
      centre(13, 26, 9),
      centre(20, 20, 9),
      centre(30, 35, 9),
      centre(2, 50, 9),
      Eigen::Vector3d(0.3183, -0.2718, 0.7071),
      centre(45, 10, 9),
      Eigen::Vector3d(1.025, 0.25, 0.7),  // on cell boundaries
      centre(26, 26, 9),
      centre(26, 26, 4),
      centre(26, 27, 4)};
  for (WeightMode mode : {WeightMode::kChordProbability, WeightMode::kPaperLiteral}) {
    for (bool templates : {true, false}) {
      VolumetricGainConfig config;
      config.certain_probability = 0.0;  // the brute force reads the stored priors as they are
      config.opaque_probability = 1.0;
      config.weight_mode = mode;
      config.use_templates = templates;
      config.entropy_sum = templates ? EntropySum::kLanes : EntropySum::kScalar;
      for (VolumetricSensor& sensor : config.sensors) {
        sensor.model.direction_uncertainty_rad = bands ? 0.0175 : 0.0;
        sensor.model.band_surface_max_m = 0.1;
      }
      VolumetricGainEvaluator evaluator(config);
      VolumetricGainStats stats, bound_stats;
      for (size_t p = 0; p < positions.size(); ++p) {
        const int n_yaw = p % 2 == 0 ? 8 : 7;
        const PoseGains got = evaluator.Evaluate(view, positions[p], n_yaw, true, &stats);
        const Brute want = BruteForce(grid, config, positions[p], n_yaw);
        if (templates && mode == WeightMode::kChordProbability) {
          gains->insert(gains->end(), got.gain_nats.begin(), got.gain_nats.end());
        }
        ExpectGainsEqual(got, want,
                         "position " + std::to_string(p) + " templates " +
                             std::to_string(templates) + " mode " +
                             std::to_string(static_cast<int>(mode)));
        const PoseGains bounds = evaluator.Evaluate(view, positions[p], n_yaw, false, &bound_stats);
        ASSERT_TRUE(bounds.gain_nats.empty());
        for (size_t m = 0; m < want.bound.size(); ++m) {
          EXPECT_NEAR(bounds.bound_nats[m], want.bound[m], 1e-9 * want.bound[m]);
        }
      }
      if (templates) {
        EXPECT_GE(stats.templates_built + bound_stats.templates_built, 2);  // z = 9 then z = 4
        EXPECT_GT(stats.templated_rays, stats.rays / 4);
      } else {
        EXPECT_EQ(stats.templated_rays, 0);
      }
      EXPECT_EQ(stats.rays_evaluated + stats.rays_skipped, stats.rays);
    }
  }
}

TEST(VolumetricGain, EqualsBruteForce) {
  std::vector<double> gains;
  CheckEqualsBruteForce(false, &gains);
}

// The same with predicted range bands; they change the gains (the model with bands is not the
// plain one where rays meet faces obliquely).
TEST(VolumetricGain, PredictedBandsEqualBruteForce) {
  std::vector<double> plain, banded;
  CheckEqualsBruteForce(false, &plain);
  CheckEqualsBruteForce(true, &banded);
  ASSERT_EQ(plain.size(), banded.size());
  int changed = 0;
  for (size_t i = 0; i < plain.size(); ++i) {
    changed += std::abs(banded[i] - plain[i]) > 1e-3 * std::abs(plain[i]) ? 1 : 0;
  }
  EXPECT_GT(changed, static_cast<int>(plain.size()) / 2);
}

// Eq. (10) with E[H] >= 0: the bound (prior entropy of the rays) is never below the gain.
TEST(VolumetricGain, BoundsAreAtLeastTheGains) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const DenseGrid grid = RandomMap(seed);
    VolumetricGainConfig raw;
    raw.certain_probability = 0.0;
    raw.opaque_probability = 1.0;
    for (const VolumetricGainConfig& config : {VolumetricGainConfig{}, raw}) {
      VolumetricGainEvaluator evaluator{config};
      std::mt19937 rng(seed);
      std::uniform_real_distribution<double> x(-0.9, 2.9), y(-1.9, 1.9), z(0.1, 1.3);
      for (int p = 0; p < 4; ++p) {
        const PoseGains r = evaluator.Evaluate(ViewOf(grid), {x(rng), y(rng), z(rng)}, 12, true);
        for (size_t m = 0; m < r.gain_nats.size(); ++m) {
          EXPECT_GE(r.bound_nats[m], r.gain_nats[m]) << "seed " << seed << " heading " << m;
          // Opaque surfaces may hide everything a heading sees (gain 0 up to rounding).
          EXPECT_GT(r.gain_nats[m], config.opaque_probability < 1.0 ? -1e-9 : 0.0);
        }
      }
    }
  }
}

// RayMemo: over a map that changes between rounds (a box of cells set to new values, a few
// single cells anywhere), the gains with a memo per position are those without, bit for bit;
// rays whose priors held are reused (fewer evaluations), and a memo's bounds stay above the
// gains. The two evaluators see the same calls in the same order (the same templates; the
// positions share one offset in their cells, as the planner's candidates do, so the templates
// are built once).
TEST(VolumetricGain, MemoReusesExactlyTheRaysWhosePriorsHeld) {
  DenseGrid grid = RandomMap(11);
  const GridGeometry& g = grid.geometry();
  const std::vector<Eigen::Vector3d> positions{
      g.CenterOf(CellIndex{13, 26, 9}), g.CenterOf(CellIndex{30, 20, 9}),
      g.CenterOf(CellIndex{45, 35, 9}), g.CenterOf(CellIndex{20, 45, 9})};
  VolumetricGainConfig config;
  VolumetricGainEvaluator with_memo(config), without(config);
  std::vector<RayMemo> memos(positions.size());
  VolumetricGainStats memo_stats, plain_stats;
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> ci(0, g.upper().x - 1), cj(0, g.upper().y - 1),
      ck(0, g.upper().z - 1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int round = 0; round < 6; ++round) {
    if (round > 0) {  // a 6 x 6 x 4 box and 20 single cells change
      const int i0 = ci(rng), j0 = cj(rng), k0 = ck(rng);
      for (int k = k0; k < std::min(k0 + 4, g.upper().z); ++k) {
        for (int j = j0; j < std::min(j0 + 6, g.upper().y); ++j) {
          for (int i = i0; i < std::min(i0 + 6, g.upper().x); ++i) {
            grid.Set(CellIndex{i, j, k}, static_cast<float>(0.02 + 0.96 * u(rng)));
          }
        }
      }
      for (int c = 0; c < 20; ++c) {
        grid.Set(CellIndex{ci(rng), cj(rng), ck(rng)}, static_cast<float>(u(rng)));
      }
    }
    const OccupancyGridView view = ViewOf(grid);
    for (size_t p = 0; p < positions.size(); ++p) {
      const PoseGains bounds =
          with_memo.Evaluate(view, positions[p], 8, false, &memo_stats, &memos[p]);
      (void)without.Evaluate(view, positions[p], 8, false, &plain_stats);
      const PoseGains got = with_memo.Evaluate(view, positions[p], 8, true, &memo_stats, &memos[p]);
      const PoseGains want = without.Evaluate(view, positions[p], 8, true, &plain_stats);
      ASSERT_EQ(got.gain_nats.size(), want.gain_nats.size());
      for (size_t m = 0; m < want.gain_nats.size(); ++m) {
        EXPECT_EQ(got.gain_nats[m], want.gain_nats[m])
            << "round " << round << " position " << p << " heading " << m;
        EXPECT_GE(bounds.bound_nats[m], want.gain_nats[m] - 1e-12 * std::abs(want.gain_nats[m]))
            << "round " << round << " position " << p << " heading " << m;
      }
    }
  }
  EXPECT_EQ(memo_stats.rays, plain_stats.rays);
  EXPECT_GT(memo_stats.rays_memo_hits, 0);
  EXPECT_LT(memo_stats.rays_evaluated, plain_stats.rays_evaluated / 2);
  std::printf("rays evaluated: %ld with memos, %ld without; memo hits %ld\n",
              memo_stats.rays_evaluated, plain_stats.rays_evaluated, memo_stats.rays_memo_hits);
}

// A known free room (1e-4) with a near-certain back wall at x 2.6..2.75: what a ray crossing the
// room meets, so that its reading is evidence (the depth camera's 0 is none:
// docs/algorithms.md §3.4).
DenseGrid BackWallRoom() {
  DenseGrid grid = MakeGrid({-1.5, -2.0, 0.0}, {4.5, 2.0, 3.0}, 0.075, 1e-4f);
  Fill(
      &grid, [](const Eigen::Vector3d& c) { return c.x() > 2.6 && c.x() < 2.75; }, 0.9999f);
  return grid;
}

// The back-wall room around the position, an unknown block (0.1) ahead in +x before the wall.
DenseGrid BlockRoom(bool wall, bool slab_unknown) {
  DenseGrid grid = BackWallRoom();
  Fill(
      &grid,
      [](const Eigen::Vector3d& c) { return c.x() > 2.0 && c.x() < 2.6 && std::abs(c.y()) < 1.0; },
      0.1f);
  if (wall) {  // a near-certain wall between the position and the block, floor to top
    Fill(
        &grid, [](const Eigen::Vector3d& c) { return c.x() > 1.5 && c.x() < 1.65; }, 0.9999f);
  }
  if (slab_unknown) {  // high above the position, outside every ray (test comment)
    Fill(
        &grid,
        [](const Eigen::Vector3d& c) {
          return c.z() > 2.2 && std::abs(c.x()) < 1.4 && std::abs(c.y()) < 1.4;
        },
        0.1f);
  }
  return grid;
}

// Visibility: the rays stop at what they see. A near-certain wall in front of the unknown block
// leaves little to learn about it (< 5% of the gain without the wall); cells above the Xtion's
// vertical FOV (elevation > 22.5 deg everywhere: the slab is 1.4 m above the sensors within
// 2 m horizontally, atan(1.4/2) = 35 deg) and off the Hokuyo's plane add nothing.
TEST(VolumetricGain, RaysSeeOnlyWhatIsVisible) {
  const Eigen::Vector3d position(0.0375, 0.0125, 0.7875);  // a cell centre
  VolumetricGainEvaluator evaluator{VolumetricGainConfig{}};
  const auto gain0 = [&](const DenseGrid& grid) {
    return evaluator.Evaluate(ViewOf(grid), position, 4, true).gain_nats[0];
  };
  const double open = gain0(BlockRoom(false, false));
  const double walled = gain0(BlockRoom(true, false));
  const DenseGrid free_room = BackWallRoom();
  DenseGrid wall_only = free_room;
  Fill(
      &wall_only, [](const Eigen::Vector3d& c) { return c.x() > 1.5 && c.x() < 1.65; }, 0.9999f);
  const double block_open = open - gain0(free_room);
  const double block_walled = walled - gain0(wall_only);
  std::printf("block gain: %.4f nats without the wall, %.4f with it (%.2f%%)\n", block_open,
              block_walled, 100.0 * block_walled / block_open);
  EXPECT_GT(block_open, 10.0);
  EXPECT_LT(block_walled, 0.05 * block_open);
  EXPECT_LT(walled, 0.05 * open);
  for (bool wall : {false, true}) {
    const PoseGains known = evaluator.Evaluate(ViewOf(BlockRoom(wall, false)), position, 8, true);
    const PoseGains unknown = evaluator.Evaluate(ViewOf(BlockRoom(wall, true)), position, 8, true);
    for (size_t m = 0; m < known.gain_nats.size(); ++m) {
      EXPECT_NEAR(unknown.gain_nats[m], known.gain_nats[m], 1e-12) << "heading " << m;
      EXPECT_NEAR(unknown.bound_nats[m], known.bound_nats[m], 1e-12) << "heading " << m;
    }
  }
}

// A camera that reports depth beyond z_max (VolumetricSensor::reports_to_m): its no-return is
// predicted as evidence exactly where the ray's point at that range lies inside the map's box and
// not above its top, and as no evidence where it leaves through a side or the top. The map is
// uncertain but mostly free (P = 0.02), so the no-return hypothesis carries most of the weight.
TEST(VolumetricGain, CameraDepthBeyondZmaxIsPredictedWhereTheMapHoldsTheRay) {
  const Eigen::Vector3d position(0.0375, 0.0375, 1.0125);  // a cell centre
  VolumetricSensor camera = XtionVolumetricSensor();
  camera.model.no_return_informs = false;
  camera.height_offset_m = 0.0;
  const auto gains = [&](const DenseGrid& grid, int rows, double reports_to_m, bool informs) {
    VolumetricSensor s = camera;
    s.rows = rows;
    s.reports_to_m = reports_to_m;
    s.model.no_return_informs = informs;
    VolumetricGainConfig config;
    config.sensors = {s};
    VolumetricGainEvaluator evaluator{config};
    return evaluator.Evaluate(ViewOf(grid), position, 4, true).gain_nats;
  };
  // One row of horizontal rays. Box 20 m wide: every 8 m point inside. 12 m wide: every one out.
  const DenseGrid wide = MakeGrid({-10.0, -10.0, 0.0}, {10.0, 10.0, 2.0}, 0.075, 0.02f);
  const DenseGrid narrow = MakeGrid({-6.0, -6.0, 0.0}, {6.0, 6.0, 2.0}, 0.075, 0.02f);
  for (const DenseGrid* grid : {&wide, &narrow}) {
    const bool inside = grid == &wide;
    const std::vector<double> silent = gains(*grid, 1, 0.0, false);
    const std::vector<double> informing = gains(*grid, 1, 0.0, true);
    const std::vector<double> reported = gains(*grid, 1, 8.0, false);
    for (size_t m = 0; m < silent.size(); ++m) {
      EXPECT_GT(informing[m], silent[m] + 1.0) << "heading " << m;
      EXPECT_EQ(reported[m], inside ? informing[m] : silent[m]) << "heading " << m;
    }
    // Every 5.9 m point lies inside both boxes (the rays' 4 m to z_max do too).
    EXPECT_EQ(gains(*grid, 1, 5.9, false), informing) << (inside ? "wide" : "narrow");
  }
  // Three rows (-15, 0, +15 deg) in the wide box with its top 2 m up: the rising row's 8 m point
  // is 3.1 m up, above the top, so only the other two rows' no-returns are evidence.
  const std::vector<double> silent = gains(wide, 3, 0.0, false);
  const std::vector<double> informing = gains(wide, 3, 0.0, true);
  const std::vector<double> reported = gains(wide, 3, 8.0, false);
  for (size_t m = 0; m < silent.size(); ++m) {
    EXPECT_GT(reported[m], silent[m] + 1.0) << "heading " << m;
    EXPECT_LT(reported[m], informing[m] - 1.0) << "heading " << m;
  }
}

// What the paper's 2D E-map could not tell apart: a map whose every cell is well known (1e-4 or
// 0.9999) has little to give, an unknown one (0.1) a lot. "Little" is not 0: a cell at P = 1e-4
// still carries H = 1.0e-3 nats, and a measurement takes about P KL(p(z | occupied) ||
// p(z | free)) of it (a few 1e-4 nats per cell seen); over the ~180 rays x ~50 cells of one
// heading that is ~1-2 nats (measured 1.5-2.2 nats per heading here, against ~180 for the
// unknown map). Bound: 2% of the unknown map's gain, and 0.05 nats per ray.
TEST(VolumetricGain, KnownMapGivesLittleUnknownMapALot) {
  DenseGrid known = MakeGrid({-3.0, -3.0, 0.0}, {3.0, 3.0, 1.5}, 0.075, 1e-4f);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (float& v : known.mutable_values()) v = u(rng) < 0.02 ? 0.9999f : 1e-4f;
  const DenseGrid free_map = MakeGrid({-3.0, -3.0, 0.0}, {3.0, 3.0, 1.5}, 0.075, 1e-4f);
  const DenseGrid unknown = MakeGrid({-3.0, -3.0, 0.0}, {3.0, 3.0, 1.5}, 0.075, 0.1f);
  // Nearly known, not at the clamp: 1e-3 free, 0.999 occupied.
  DenseGrid nearly = MakeGrid({-3.0, -3.0, 0.0}, {3.0, 3.0, 1.5}, 0.075, 1e-3f);
  for (float& v : nearly.mutable_values()) v = u(rng) < 0.02 ? 0.999f : 1e-3f;
  const Eigen::Vector3d position(0.0375, 0.0375, 0.7125);
  // Three camera rows, as measured (with five, the camera's returns off the free map's clamped
  // cells, which raise the hit cell's entropy, outweigh the LIDAR's no-returns in the raw reading).
  VolumetricGainConfig clamp_config;
  clamp_config.sensors[0].rows = 3;
  VolumetricGainConfig raw_config = clamp_config;
  raw_config.certain_probability = 0.0;  // the clamp's entropy counted as it is stored
  for (const VolumetricGainConfig& config : {clamp_config, raw_config}) {
    const bool clamp_certain = config.certain_probability > 0.0;
    VolumetricGainEvaluator evaluator{config};
    VolumetricGainStats stats;
    const PoseGains n = evaluator.Evaluate(ViewOf(unknown), position, 8, true);
    const PoseGains f = evaluator.Evaluate(ViewOf(free_map), position, 8, true);
    const PoseGains k = evaluator.Evaluate(ViewOf(known), position, 8, true);
    const PoseGains e = evaluator.Evaluate(ViewOf(nearly), position, 8, true);
    evaluator.Evaluate(ViewOf(known), position, 1, true, &stats);  // the rays of one heading
    double worst = 0.0, worst_free = 0.0;
    for (size_t m = 0; m < k.gain_nats.size(); ++m) {
      worst = std::max(worst, std::abs(k.gain_nats[m]));
      worst_free = std::max(worst_free, std::abs(f.gain_nats[m]));
      EXPECT_GT(n.gain_nats[m], 50.0) << "heading " << m;
      EXPECT_GT(e.gain_nats[m], 0.5) << "heading " << m;  // 1e-3 is not the clamp: still counts
      EXPECT_LT(e.gain_nats[m], 0.15 * n.gain_nats[m]) << "heading " << m;
      if (clamp_certain) {
        // At the clamp nothing is left to learn: zero up to rounding.
        EXPECT_NEAR(k.gain_nats[m], 0.0, 1e-9) << "heading " << m;
        EXPECT_NEAR(f.gain_nats[m], 0.0, 1e-9) << "heading " << m;
        EXPECT_EQ(k.bound_nats[m], 0.0) << "heading " << m;
      } else {
        // The clamp's own entropy: small against unknown, yet several nats per heading.
        EXPECT_LT(std::abs(k.gain_nats[m]), 0.02 * n.gain_nats[m]) << "heading " << m;
        EXPECT_LT(std::abs(f.gain_nats[m]), 0.02 * n.gain_nats[m]) << "heading " << m;
        EXPECT_LT(std::abs(k.gain_nats[m]), 0.05 * static_cast<double>(stats.rays));
        // Nothing to return from in the free map: only the LIDAR's no-returns teach (the
        // camera's 0 is no evidence, docs/algorithms.md §3.4).
        EXPECT_GT(f.gain_nats[m], 0.05) << "heading " << m;
      }
    }
    std::printf(
        "certain_probability %g: max |gain| per heading: known map %.4g nats, free map %.4g nats "
        "(%ld rays); nearly known %.4g nats; unknown map %.4g nats\n",
        config.certain_probability, worst, worst_free, stats.rays, e.gain_nats[0], n.gain_nats[0]);
  }
}

// A map symmetric under rotation by 90 deg about the position: headings 0 and pi/2 see the same
// (azimuth_bins a multiple of 4, so the bins rotate onto bins). Not a multiple of 8: a 45 deg
// ray from a cell centre passes exactly through cell corners, where the DDA's crossings tie up
// to rounding, and rounding (which depends on the absolute coordinates, not on the rotation)
// decides whether a sliver cell is listed; with 120 bins the headings then differ by ~1e-5
// relative, in the brute force as well (the exactness test covers those rays).
TEST(VolumetricGain, RotationSymmetricMapGivesEqualHeadings) {
  DenseGrid grid = MakeGrid({-2.2125, -2.2125, 0.0}, {2.19, 2.19, 1.5}, 0.075, 0.1f);
  const CellIndex d = grid.dims();
  ASSERT_EQ(d.x, 59);
  ASSERT_EQ(d.y, 59);
  const int c = 29;  // the cell (29, 29) is centred on x = y = 0
  for (int k = 0; k < d.z; ++k) {
    for (int j = 0; j < d.y; ++j) {
      for (int i = 0; i < d.x; ++i) {
        // Invariant under (i, j) -> (-j, i) about c, not under mirror images: a pinwheel.
        int a = i - c, b = j - c;
        while (!(a > 0 && b >= 0) && !(a == 0 && b == 0)) {  // rotate into the first quadrant
          const int t = a;
          a = -b;
          b = t;
        }
        const unsigned h = static_cast<unsigned>(a * 7919 + b * 104729 + k * 1299709) * 2654435761u;
        const double r = static_cast<double>(h >> 8) / 16777216.0;
        grid.Set(CellIndex{i, j, k}, static_cast<float>(r < 0.4 ? 0.1 : r < 0.6 ? 1e-4 : r));
      }
    }
  }
  const Eigen::Vector3d position = grid.geometry().CenterOf(CellIndex{c, c, 9});
  for (int bins : {60, 36, 100}) {
    VolumetricGainConfig config;
    config.opaque_probability = 1.0;  // every cell as stored: the sliver cells of the comment
    config.azimuth_bins = bins;
    VolumetricGainEvaluator evaluator(config);
    const PoseGains r = evaluator.Evaluate(ViewOf(grid), position, 4, true);
    for (int m = 1; m < 4; ++m) {
      EXPECT_NEAR(r.gain_nats[static_cast<size_t>(m)], r.gain_nats[0], 1e-9 * r.gain_nats[0])
          << "bins " << bins << " heading " << m;
    }
    // Not trivially equal: another heading set sees something else.
    const PoseGains r8 = evaluator.Evaluate(ViewOf(grid), position, 8, true);
    EXPECT_GT(std::abs(r8.gain_nats[1] - r8.gain_nats[0]), 1e-6 * r8.gain_nats[0]);
  }
}

// Visibility of fuzzy surfaces (VolumetricGainConfig::opaque_probability): a one-cell wall that
// the sensor model has left at P = 0.6 in front of an unknown block. Read as it is stored, the
// exact model still predicts a glimpse behind it, a gain no flight collects (the sensor keeps
// hitting the wall); read as opaque, the block adds nothing: the gain equals that of the same room
// with the block already known, bit for bit. A wall at 0.3 (less likely occupied than not) stays
// transparent.
TEST(VolumetricGain, OpaqueSurfaces) {
  auto room = [](float wall_p, bool block_known) {
    DenseGrid grid = MakeGrid({-1.5, -2.0, 0.0}, {4.5, 2.0, 2.0}, 0.075, 1e-4f);
    Fill(
        &grid,
        [](const Eigen::Vector3d& c) {
          return c.x() > 2.0 && c.x() < 3.5 && std::abs(c.y()) < 1.5;
        },
        block_known ? 1e-4f : 0.1f);
    Fill(
        &grid, [](const Eigen::Vector3d& c) { return c.x() > 1.5 && c.x() < 1.575; }, wall_p);
    return grid;
  };
  const Eigen::Vector3d position(0.0375, 0.0375, 0.7125);
  VolumetricGainConfig stored;
  stored.opaque_probability = 1.0;
  VolumetricGainEvaluator opaque{VolumetricGainConfig{}};
  VolumetricGainEvaluator as_stored{stored};
  const double behind = opaque.Evaluate(ViewOf(room(0.6f, false)), position, 1, true).gain_nats[0];
  const double known = opaque.Evaluate(ViewOf(room(0.6f, true)), position, 1, true).gain_nats[0];
  EXPECT_EQ(behind, known);
  const double glimpse =
      as_stored.Evaluate(ViewOf(room(0.6f, false)), position, 1, true).gain_nats[0] -
      as_stored.Evaluate(ViewOf(room(0.6f, true)), position, 1, true).gain_nats[0];
  EXPECT_GT(glimpse, 1.0);
  const double through =
      opaque.Evaluate(ViewOf(room(0.3f, false)), position, 1, true).gain_nats[0] -
      opaque.Evaluate(ViewOf(room(0.3f, true)), position, 1, true).gain_nats[0];
  EXPECT_GT(through, 1.0);
  std::printf(
      "wall at 0.6: the block adds %.3f nats read as stored, 0 read as opaque; wall at "
      "0.3: %.3f nats\n",
      glimpse, through);
}

void ExpectThrowsNaming(const VolumetricGainConfig& config, const std::string& field) {
  try {
    config.Validate();
    ADD_FAILURE() << "no throw for " << field;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
  }
  EXPECT_THROW(VolumetricGainEvaluator{config}, std::invalid_argument);
}

TEST(VolumetricGain, InvalidConfigThrowsNamingTheField) {
  EXPECT_NO_THROW(VolumetricGainConfig{}.Validate());
  VolumetricGainConfig c;
  c.azimuth_bins = 0;
  ExpectThrowsNaming(c, "azimuth_bins");
  c = VolumetricGainConfig{};
  c.sensors[0].horizontal_fov_rad = 0.0;
  ExpectThrowsNaming(c, "horizontal_fov_rad");
  c.sensors[0].horizontal_fov_rad = 7.0;
  ExpectThrowsNaming(c, "horizontal_fov_rad");
  c = VolumetricGainConfig{};
  c.sensors[0].vertical_fov_rad = -0.1;
  ExpectThrowsNaming(c, "vertical_fov_rad");
  c.sensors[0].vertical_fov_rad = M_PI;
  ExpectThrowsNaming(c, "vertical_fov_rad");
  c = VolumetricGainConfig{};
  c.sensors[0].rows = 0;
  ExpectThrowsNaming(c, "rows");
  c = VolumetricGainConfig{};
  c.sensors[1].rows = 3;  // the planar Hokuyo
  ExpectThrowsNaming(c, "rows");
  c = VolumetricGainConfig{};
  c.sensors.clear();
  ExpectThrowsNaming(c, "sensors");
  c = VolumetricGainConfig{};
  c.min_ray_bound_nats = -1.0;
  ExpectThrowsNaming(c, "min_ray_bound_nats");
  VolumetricGainEvaluator e{VolumetricGainConfig{}};
  const DenseGrid grid = RandomMap(1);
  EXPECT_THROW(e.Evaluate(ViewOf(grid), {0.0, 0.0, 0.5}, 0, true), std::invalid_argument);
}

// The approximation switch, off in every test above: its error on a half-known room.
TEST(VolumetricGain, ApproximationErrorIsMeasured) {
  // A room: known free inside x < 1 (1e-4), unknown beyond, near-certain walls and a pillar.
  DenseGrid grid = MakeGrid({-2.0, -3.0, 0.0}, {4.0, 3.0, 1.5}, 0.075, 0.1f);
  Fill(
      &grid, [](const Eigen::Vector3d& c) { return c.x() < 1.0; }, 1e-4f);
  Fill(
      &grid,
      [](const Eigen::Vector3d& c) {
        return c.x() < -1.8 || std::abs(c.y()) > 2.8 || c.z() < 0.075 ||
               (std::abs(c.x() - 0.3) < 0.2 && std::abs(c.y() + 0.8) < 0.2);
      },
      0.9999f);
  const Eigen::Vector3d position = grid.geometry().CenterOf(CellIndex{20, 40, 10});
  VolumetricGainEvaluator exact{VolumetricGainConfig{}};
  const PoseGains want = exact.Evaluate(ViewOf(grid), position, 16, true);
  long rays_per_heading = 0;
  {
    VolumetricGainStats stats;
    exact.Evaluate(ViewOf(grid), position, 1, true, &stats);
    rays_per_heading = stats.rays;
  }
  for (double threshold : {0.03, 0.05, 0.1}) {
    VolumetricGainConfig config;
    config.min_ray_bound_nats = threshold;
    VolumetricGainEvaluator approx(config);
    VolumetricGainStats stats;
    const PoseGains got = approx.Evaluate(ViewOf(grid), position, 16, true, &stats);
    double worst = 0.0, worst_rel = 0.0;
    for (size_t m = 0; m < want.gain_nats.size(); ++m) {
      const double err = std::abs(got.gain_nats[m] - want.gain_nats[m]);
      worst = std::max(worst, err);
      worst_rel = std::max(worst_rel, err / want.gain_nats[m]);
      EXPECT_LE(err, threshold * static_cast<double>(rays_per_heading)) << "heading " << m;
    }
    std::printf("min_ray_bound_nats %g: %ld of %ld rays skipped, max error %.3g nats (%.3g%%)\n",
                threshold, stats.rays_skipped, stats.rays, worst, 100.0 * worst_rel);
  }
}

}  // namespace
}  // namespace kestrel
