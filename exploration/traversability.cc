#include "exploration/traversability.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/check.h"

namespace kestrel {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// One row of the Felzenszwalb-Huttenlocher transform: d[q] = min_p (q - p)^2 + f[p] over n
// samples. v and z are scratch of size n and n + 1.
void DistanceTransform1D(const double* f, int n, double* d, std::vector<int>* v_scratch,
                         std::vector<double>* z_scratch) {
  std::vector<int>& v = *v_scratch;
  std::vector<double>& z = *z_scratch;
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (!std::isfinite(f[q])) continue;
    if (k < 0) {
      k = 0;
      v[0] = q;
      z[0] = -kInf;
      z[1] = kInf;
      continue;
    }
    double s = 0.0;
    while (true) {
      const int p = v[static_cast<size_t>(k)];
      s = ((f[q] + static_cast<double>(q) * q) - (f[p] + static_cast<double>(p) * p)) /
          (2.0 * (q - p));
      if (s <= z[static_cast<size_t>(k)] && k > 0) {
        --k;
        continue;
      }
      break;
    }
    ++k;
    v[static_cast<size_t>(k)] = q;
    z[static_cast<size_t>(k)] = s;
    z[static_cast<size_t>(k) + 1] = kInf;
  }
  if (k < 0) {
    std::fill(d, d + n, kInf);
    return;
  }
  int j = 0;
  for (int q = 0; q < n; ++q) {
    while (z[static_cast<size_t>(j) + 1] < q) ++j;
    const int p = v[static_cast<size_t>(j)];
    d[q] = static_cast<double>(q - p) * (q - p) + f[p];
  }
}

// Step 3b of the file comment. Lengths in cells; a blocked square's lower corner `lo`, its
// extent [lo, lo + 1]^2.
struct Nearest {
  double d{std::numeric_limits<double>::infinity()};
  Eigen::Vector2d a{0.0, 0.0};  // the nearest point of the nearest square
};

Eigen::Vector2d ClampToSquare(const Eigen::Vector2d& p, const Eigen::Vector2d& lo) {
  return {std::clamp(p.x(), lo.x(), lo.x() + 1.0), std::clamp(p.y(), lo.y(), lo.y() + 1.0)};
}

Nearest NearestSurface(const std::vector<Eigen::Vector2d>& squares, const Eigen::Vector2d& p) {
  Nearest n;
  for (const Eigen::Vector2d& lo : squares) {
    const Eigen::Vector2d a = ClampToSquare(p, lo);
    const double d = (a - p).norm();
    if (d < n.d) n = {d, a};
  }
  return n;
}

// The nearest surface on the far side of p from n.a: squares whose nearest point a has
// (a - p).(n.a - p) < kOpposite |a - p| n.d, more than 110 deg away. Not just past 90 deg: on a
// room's 90 deg inner corner's bisector, at distance d from both walls, the points of one wall
// just past its foot lie a little over 90 deg from the other wall's foot at almost the same
// distance; past 110 deg they are 0.063 d farther (0.38 cells at the passage clearance, beyond
// tol), so a corner is no gap. A door's middle line keeps its surfaces more than 110 deg apart
// until its clearance is 1/sin(55 deg) = 1.22 times the door's half width (0.558 m for a door
// mapped 0.91 m wide), past the required clearance, where its cells are traversable.
constexpr double kOpposite = -0.34;

double OppositeDistance(const std::vector<Eigen::Vector2d>& squares, const Eigen::Vector2d& p,
                        const Nearest& n) {
  double best = std::numeric_limits<double>::infinity();
  const Eigen::Vector2d toward = n.a - p;
  for (const Eigen::Vector2d& lo : squares) {
    const Eigen::Vector2d e = ClampToSquare(p, lo) - p;
    const double d = e.norm();
    if (d < best && e.dot(toward) < kOpposite * d * n.d) best = d;
  }
  return best;
}

// Samples per cell edge of the passage search (file comment, step 3b).
constexpr int kPassageSamples = 10;
// How close to its cell's edges a passage point may come, in cells.
constexpr double kInside = 1e-4;

// Step 3b of the file comment: in every free cell that is not traversable, the point of largest
// clearance to the blocked cells' surfaces (exact, the squares themselves, not their centres)
// among the points of the cell that lie on a gap's middle line: their nearest surfaces on two
// opposite sides at distances within 2 samples' spacing of each other. A clearance >= need makes
// the cell a passage cell with that point. `site` is the padded blocked grid (width pw).
void FindPassages(const std::vector<bool>& site, int pw, const TraversabilityConfig& config,
                  const std::vector<bool>& free, Traversability* t) {
  const GridMap2D& grid = t->clearance;
  const double alpha = grid.resolution_m;
  const int w = grid.width;
  const int h = grid.height;
  const int ph = h + 2;
  const double need_m = config.passage_clearance_m();
  const double need = need_m / alpha;
  const double radius = config.vehicle_radius_m / alpha;
  const double step = 1.0 / kPassageSamples;
  const double tol = 2.0 * step;
  // Candidates have a centre clearance below the required one (it over-reads the surface distance
  // by less than 0.25 cells), so their points lie within top of a surface; their opposite
  // surface within top + tol.
  const double top = config.required_clearance_m() / alpha + 1.0;
  const int reach = static_cast<int>(std::ceil(top + tol + 1.0)) + 1;
  // Only blocked squares with a free 4-neighbour can hold a nearest point.
  std::vector<bool> edge(site.size(), false);
  for (int v = 0; v < ph; ++v) {
    for (int u = 0; u < pw; ++u) {
      if (!site[static_cast<size_t>(u + pw * v)]) continue;
      bool open = false;
      for (const auto& [du, dv] :
           {std::pair{1, 0}, std::pair{-1, 0}, std::pair{0, 1}, std::pair{0, -1}}) {
        const int uu = u + du;
        const int vv = v + dv;
        if (uu >= 0 && vv >= 0 && uu < pw && vv < ph && !site[static_cast<size_t>(uu + pw * vv)])
          open = true;
      }
      edge[static_cast<size_t>(u + pw * v)] = open;
    }
  }
  std::vector<Eigen::Vector2d> squares;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(x) + static_cast<size_t>(w) * static_cast<size_t>(y);
      // The clearance changes by at most sqrt(1/2) cells within a cell, and the centre's reads
      // at most 0.25 cells above the surface distance: a cell below need - 1 has no passage point.
      if (!free[i] || t->traversable[i] || t->clearance.values[i] < need_m - alpha) continue;
      squares.clear();
      for (int v = std::max(0, y + 1 - reach); v <= std::min(ph - 1, y + 1 + reach); ++v) {
        for (int u = std::max(0, x + 1 - reach); u <= std::min(pw - 1, x + 1 + reach); ++u) {
          // Padded cell (u, v) is the map's (u - 1, v - 1).
          if (edge[static_cast<size_t>(u + pw * v)]) squares.emplace_back(u - 1, v - 1);
        }
      }
      if (squares.empty()) continue;
      // A gap at all: from the centre, a surface within reach of the nearest one's distance and
      // at least 60 deg away from it (a point of the cell on a middle line has its two surfaces
      // more than 110 deg apart, each seen from the centre at most about 15 deg off).
      const Eigen::Vector2d c(x + 0.5, y + 0.5);
      const Nearest nc = NearestSurface(squares, c);
      bool gap = false;
      for (const Eigen::Vector2d& lo : squares) {
        const Eigen::Vector2d e = ClampToSquare(c, lo) - c;
        const double d = e.norm();
        if (d <= nc.d + tol + 2.0 && e.dot(nc.a - c) <= 0.5 * d * nc.d) {
          gap = true;
          break;
        }
      }
      if (!gap) continue;
      // A point of the cell is within sqrt(1/2) of c, so its nearest surface within nc.d +
      // sqrt(1/2) of it and its opposite one within tol more: farther squares cannot matter.
      const double keep = nc.d + tol + 1.5;
      squares.erase(std::remove_if(squares.begin(), squares.end(),
                                   [&](const Eigen::Vector2d& lo) {
                                     return (ClampToSquare(c, lo) - c).norm() > keep;
                                   }),
                    squares.end());
      // On a middle line with at least `floor` of clearance: its clearance, else -1.
      const auto on_middle = [&](const Eigen::Vector2d& p, double floor, Nearest* n) {
        *n = NearestSurface(squares, p);
        if (n->d < floor) return -1.0;
        return OppositeDistance(squares, p, *n) - n->d <= tol ? n->d : -1.0;
      };
      double best = -1.0;
      Eigen::Vector2d q = c;
      Nearest nq;
      for (int j = 0; j < kPassageSamples; ++j) {
        for (int k = 0; k < kPassageSamples; ++k) {
          const Eigen::Vector2d p(x + (k + 0.5) * step, y + (j + 0.5) * step);
          // The clearance grows by at most |p - c| from the centre's: skip what cannot qualify.
          if (nc.d + (p - c).norm() < std::max(need, best + 1e-12)) continue;
          Nearest n;
          const double d = on_middle(p, std::max(need, best + 1e-12), &n);
          if (d > best) {
            best = d;
            q = p;
            nq = n;
          }
        }
      }
      if (best < need) continue;
      // Refine: pattern search inside the cell, on the middle line, towards more clearance.
      for (double s = 0.5 * step; s > 1e-3; s *= 0.5) {
        bool moved = true;
        while (moved) {
          moved = false;
          for (const auto& [dx, dy] :
               {std::pair{1, 0}, std::pair{-1, 0}, std::pair{0, 1}, std::pair{0, -1},
                std::pair{1, 1}, std::pair{1, -1}, std::pair{-1, 1}, std::pair{-1, -1}}) {
            const Eigen::Vector2d p = q + s * Eigen::Vector2d(dx, dy);
            // Inside the cell (a hair off its edges, which belong to its neighbours).
            if (p.x() < x + kInside || p.x() > x + 1 - kInside || p.y() < y + kInside ||
                p.y() > y + 1 - kInside) {
              continue;
            }
            Nearest n;
            const double d = on_middle(p, best + 1e-9, &n);
            if (d > best) {
              best = d;
              q = p;
              nq = n;
              moved = true;
            }
          }
        }
      }
      t->clearance.values[i] = best * alpha;
      t->passage_points[static_cast<int>(i)] = grid.origin_m + q * alpha;
      t->passage_across[static_cast<int>(i)] = {(nq.a - q) / nq.d,
                                                std::min(0.5 * alpha, (best - radius) * alpha)};
    }
  }
}

}  // namespace

void TraversabilityConfig::Validate() const {
  KESTREL_THROW_UNLESS(std::isfinite(height_m),
                       "traversability height_m = " << height_m << ", accepted finite");
  KESTREL_THROW_UNLESS(std::isfinite(band_below_m) && band_below_m > 0.0,
                       "traversability.band_below_m = " << band_below_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(band_above_m) && band_above_m > 0.0,
                       "traversability.band_above_m = " << band_above_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(vehicle_radius_m) && vehicle_radius_m > 0.0,
      "traversability vehicle_radius_m = " << vehicle_radius_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(margin_m) && margin_m >= 0.0,
                       "traversability.margin_m = " << margin_m << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(free_threshold > 0.0 && free_threshold < 1.0,
                       "traversability free_threshold = " << free_threshold << ", accepted (0, 1)");
  KESTREL_THROW_UNLESS(p_init > 0.0 && p_init < 1.0,
                       "traversability p_init = " << p_init << ", accepted (0, 1)");
  KESTREL_THROW_UNLESS(
      std::isfinite(preferred_extra_m) && preferred_extra_m >= 0.0,
      "traversability preferred_extra_m = " << preferred_extra_m << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(clearance_weight) && clearance_weight >= 0.0,
      "traversability clearance_weight = " << clearance_weight << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(passage_margin_m) && passage_margin_m >= 0.0,
      "traversability passage_margin_m = " << passage_margin_m << ", accepted [0, inf)");
}

std::vector<double> SquaredDistanceTransform(int width, int height, const std::vector<bool>& site) {
  KESTREL_THROW_UNLESS(width >= 0 && height >= 0 &&
                           site.size() == static_cast<size_t>(width) * static_cast<size_t>(height),
                       "SquaredDistanceTransform: " << site.size() << " sites for " << width
                                                    << " x " << height << " cells");
  const size_t n = site.size();
  std::vector<double> d(n, kInf);
  if (n == 0) return d;
  const int longest = std::max(width, height);
  std::vector<int> v(static_cast<size_t>(longest));
  std::vector<double> z(static_cast<size_t>(longest) + 1);
  std::vector<double> f(static_cast<size_t>(longest));
  std::vector<double> out(static_cast<size_t>(longest));
  // Pass 1, along x: f = 0 at sites, +inf elsewhere.
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      f[static_cast<size_t>(x)] = site[static_cast<size_t>(x + width * y)] ? 0.0 : kInf;
    }
    DistanceTransform1D(f.data(), width, out.data(), &v, &z);
    for (int x = 0; x < width; ++x)
      d[static_cast<size_t>(x + width * y)] = out[static_cast<size_t>(x)];
  }
  // Pass 2, along y, on the row results.
  for (int x = 0; x < width; ++x) {
    for (int y = 0; y < height; ++y)
      f[static_cast<size_t>(y)] = d[static_cast<size_t>(x + width * y)];
    DistanceTransform1D(f.data(), height, out.data(), &v, &z);
    for (int y = 0; y < height; ++y)
      d[static_cast<size_t>(x + width * y)] = out[static_cast<size_t>(y)];
  }
  return d;
}

Traversability ComputeTraversability(const OccupancyGridView& map,
                                     const TraversabilityConfig& config,
                                     const std::optional<StartupFreeZone>& startup,
                                     const std::vector<Eigen::Vector2d>* flown) {
  map.Validate();
  config.Validate();
  const double alpha = map.resolution_m;
  const int w = map.dims.x();
  const int h = map.dims.y();
  const Eigen::Vector2d origin = map.origin_m.head<2>();
  Traversability t;
  t.band = GridMap2D::Filled(origin, alpha, config.height_m, w, h, 1.0);
  t.clearance = GridMap2D::Filled(origin, alpha, config.height_m, w, h, 0.0);

  // The band's 3D layers: z extent [z0 + k alpha, z0 + (k+1) alpha) overlapping the open band
  // (h - below, h + above) by more than 1e-9 m (rounding), as the projections do.
  const double lo = config.height_m - config.band_below_m;
  const double hi = config.height_m + config.band_above_m;
  int k_lo = map.dims.z();
  int k_hi = -1;
  for (int k = 0; k < map.dims.z(); ++k) {
    const double z0 = map.origin_m.z() + k * alpha;
    if (std::min(z0 + alpha, hi) - std::max(z0, lo) > 1e-9) {
      k_lo = std::min(k_lo, k);
      k_hi = std::max(k_hi, k);
    }
  }
  // A band that leaves the map vertically counts as unknown: everything stays blocked.
  const bool band_inside = k_hi >= 0 && map.origin_m.z() <= lo + 1e-9 &&
                           map.origin_m.z() + map.dims.z() * alpha >= hi - 1e-9;
  if (band_inside) {
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        double p_max = 0.0;
        for (int k = k_lo; k <= k_hi; ++k) p_max = std::max(p_max, map.At(x, y, k));
        t.band.at(x, y) = p_max;
      }
    }
  }

  std::vector<bool> free(static_cast<size_t>(w) * static_cast<size_t>(h), false);
  t.unknown.assign(free.size(), false);
  for (size_t i = 0; i < free.size(); ++i) {
    const double p = t.band.values[i];
    free[i] = p <= config.free_threshold;
    t.unknown[i] = !free[i] && band_inside && p >= 0.5 * config.p_init && p <= 0.5;
  }
  if (band_inside && startup) {
    const double r2 = startup->radius_m * startup->radius_m;
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const size_t i = static_cast<size_t>(x + w * y);
        // The map stores floats: P_init as stored is float(p_init), a hair above p_init.
        if (free[i] || t.band.values[i] > static_cast<double>(static_cast<float>(config.p_init))) {
          continue;
        }
        if ((t.band.CenterOf({x, y}) - startup->center_m).squaredNorm() <= r2) {
          free[i] = true;
          t.unknown[i] = false;
        }
      }
    }
  }
  // Clearance: distance to the nearest blocked cell, the map's outside included (a ring of
  // blocked cells around the grid).
  const int pw = w + 2;
  const int ph = h + 2;
  std::vector<bool> site(static_cast<size_t>(pw) * static_cast<size_t>(ph), true);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      site[static_cast<size_t>((x + 1) + pw * (y + 1))] = !free[static_cast<size_t>(x + w * y)];
    }
  }
  const std::vector<double> d2 = SquaredDistanceTransform(pw, ph, site);
  t.traversable.assign(free.size(), false);
  const double need = config.required_clearance_m();
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(x + w * y);
      const double c =
          free[i]
              ? std::max(0.0, std::sqrt(d2[static_cast<size_t>((x + 1) + pw * (y + 1))]) * alpha -
                                  0.5 * alpha)
              : 0.0;
      t.clearance.values[i] = c;
      t.traversable[i] = free[i] && c >= need;
    }
  }
  FindPassages(site, pw, config, free, &t);
  if (band_inside && flown != nullptr && flown->size() >= 2) {
    // The flown corridor (file comment): the vehicle's centre has been along these segments
    // (consecutive points at most kMaxFlownGap apart).
    constexpr double kMaxFlownGap = 1.0;
    // Pose and tracking error allowed between the flown points and where the body really was, m.
    constexpr double kCarveTolerance = 0.02;
    // Cells whose whole square lay inside the vehicle's disc somewhere along the flown path:
    // the body has been there, so whatever occupied cells the map holds there are noise.
    const double carve = config.vehicle_radius_m - alpha * std::sqrt(0.5) - kCarveTolerance;
    const double near = 1.5 * alpha;  // the corridor: cells this close to the flown path
    std::vector<double> flown_distance(free.size(), kInf);
    const int reach = static_cast<int>(std::ceil(std::max(carve, near) / alpha)) + 1;
    for (size_t s = 0; s + 1 < flown->size(); ++s) {
      const Eigen::Vector2d a = (*flown)[s];
      const Eigen::Vector2d b = (*flown)[s + 1];
      const Eigen::Vector2d ab = b - a;
      const double len = ab.norm();
      if (!(len <= kMaxFlownGap)) continue;
      // The segment's bounding box in cells, widened by reach and clipped to the grid.
      const Eigen::Vector2d lo_c = (a.cwiseMin(b) - origin) / alpha;
      const Eigen::Vector2d hi_c = (a.cwiseMax(b) - origin) / alpha;
      const int x0 = std::max(0, static_cast<int>(std::floor(lo_c.x())) - reach);
      const int y0 = std::max(0, static_cast<int>(std::floor(lo_c.y())) - reach);
      const int x1 = std::min(w - 1, static_cast<int>(std::floor(hi_c.x())) + reach);
      const int y1 = std::min(h - 1, static_cast<int>(std::floor(hi_c.y())) + reach);
      for (int y = y0; y <= y1; ++y) {
        for (int x = x0; x <= x1; ++x) {
          const Eigen::Vector2d cp = t.band.CenterOf({x, y});
          const double u =
              len > 0 ? std::clamp((cp - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
          double& d = flown_distance[static_cast<size_t>(x + w * y)];
          d = std::min(d, (a + u * ab - cp).norm());
        }
      }
    }
    // Clearance there: to the known occupied cells (P > 0.5, and the map's outside) that were not
    // carved; uncertain cells (sensor noise since) are ignored. The vehicle has flown the path, so
    // its radius suffices: the margin's uncertainty has been resolved by the flight itself.
    std::vector<bool> occupied(static_cast<size_t>(pw) * static_cast<size_t>(ph), true);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const size_t i = static_cast<size_t>(x + w * y);
        occupied[static_cast<size_t>((x + 1) + pw * (y + 1))] =
            t.band.values[i] > 0.5 && !(flown_distance[i] <= carve);
      }
    }
    const std::vector<double> o2 = SquaredDistanceTransform(pw, ph, occupied);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const size_t i = static_cast<size_t>(x + w * y);
        if (t.traversable[i] || !(flown_distance[i] <= near)) continue;
        const size_t pi = static_cast<size_t>((x + 1) + pw * (y + 1));
        if (occupied[pi]) continue;
        if (std::sqrt(o2[pi]) * alpha - 0.5 * alpha >= config.vehicle_radius_m) {
          t.traversable[i] = true;
          t.unknown[i] = false;
        }
      }
    }
  }
  return t;
}

std::vector<double> ClearanceStepWeights(const Traversability& map,
                                         const TraversabilityConfig& config) {
  config.Validate();
  std::vector<double> w;
  if (config.preferred_extra_m <= 0.0 || config.clearance_weight <= 0.0) return w;
  const double preferred = config.required_clearance_m() + config.preferred_extra_m;
  w.resize(map.clearance.values.size());
  for (size_t i = 0; i < w.size(); ++i) {
    const double s =
        std::clamp((preferred - map.clearance.values[i]) / config.preferred_extra_m, 0.0, 1.0);
    w[i] = 1.0 + config.clearance_weight * s * s;
  }
  return w;
}

int AllowPassages(const Traversability& map, std::vector<bool>* traversable) {
  KESTREL_THROW_UNLESS(
      traversable != nullptr && traversable->size() == static_cast<size_t>(map.band.size()),
      "AllowPassages: traversable flags do not match the map");
  int added = 0;
  for (const auto& [cell, point] : map.passage_points) {
    std::vector<bool>::reference flag = (*traversable)[static_cast<size_t>(cell)];
    if (!flag) ++added;
    flag = true;
  }
  return added;
}

int AllowEscape(const Traversability& map, const TraversabilityConfig& config,
                const Eigen::Vector2d& p_m, double escape_radius_m,
                std::vector<bool>* traversable) {
  KESTREL_THROW_UNLESS(
      traversable != nullptr && traversable->size() == static_cast<size_t>(map.band.size()),
      "AllowEscape: traversable flags do not match the map");
  const std::optional<Cell2> c = map.band.CellOf(p_m);
  if (!c) return 0;
  const size_t own = static_cast<size_t>(map.band.IndexOf(*c));
  if (map.traversable[own]) return 0;
  const double alpha = map.band.resolution_m;
  // Never tighter than here: a floor below the vehicle's own clearance would let each replan
  // take it a little closer to the obstacle, plan after plan.
  const double floor = std::min(map.clearance.values[own], config.required_clearance_m());
  const int reach = static_cast<int>(std::ceil(escape_radius_m / alpha));
  int added = 0;
  for (int y = std::max(0, c->y - reach); y <= std::min(map.band.height - 1, c->y + reach); ++y) {
    for (int x = std::max(0, c->x - reach); x <= std::min(map.band.width - 1, c->x + reach); ++x) {
      const size_t i = static_cast<size_t>(map.band.IndexOf(x, y));
      if ((*traversable)[i] || map.clearance.values[i] <= 0.0 || map.clearance.values[i] < floor) {
        continue;
      }
      if ((map.band.CenterOf({x, y}) - p_m).norm() <= escape_radius_m) {
        (*traversable)[i] = true;
        ++added;
      }
    }
  }
  return added;
}

}  // namespace kestrel
