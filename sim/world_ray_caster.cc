#include "sim/world_ray_caster.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <thread>

#include "common/check.h"

namespace kestrel {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kMaxBinsPerAxis = 256;

// Slab interval of one axis: the ray o + t u lies within [-h, h] (or [lo, hi]) for t in [*t0, *t1].
// Returns false when the ray is parallel to the slab and outside it.
inline bool Slab(double o, double u, double lo, double hi, double* t0, double* t1) {
  if (u == 0.0) {
    if (o < lo || o > hi) return false;
    *t0 = -kInf;
    *t1 = kInf;
    return true;
  }
  const double inv = 1.0 / u;
  double a = (lo - o) * inv;
  double b = (hi - o) * inv;
  if (a > b) std::swap(a, b);
  *t0 = a;
  *t1 = b;
  return true;
}

// Narrows [*t0, *t1] to the ray's interval inside the slab [lo, hi] of one axis, given
// lo - o, hi - o and inv = 1/u (+-inf when u is +-0). No test on u: for u = 0 the products are
// +-inf (outside the slab: the interval empties; inside: no constraint) or NaN when o lies on a
// face, which leaves the interval as it is (a ray in a face plane is inside the closed slab).
inline void SlabBranchless(double lo_minus_o, double hi_minus_o, double inv, double* t0,
                           double* t1) {
  const double ta = lo_minus_o * inv;
  const double tb = hi_minus_o * inv;
  if (std::isnan(ta) || std::isnan(tb)) return;
  *t0 = std::max(*t0, std::min(ta, tb));
  *t1 = std::min(*t1, std::max(ta, tb));
}

}  // namespace

WorldRayCaster::WorldRayCaster(const World& world, double bin_m, Accelerator accelerator)
    : accelerator_(accelerator) {
  KESTREL_THROW_UNLESS(std::isfinite(bin_m) && bin_m > 0.0,
                       "ray caster bin size " << bin_m << " m must be positive and finite");
  for (const WorldBox& b : world.boxes) {
    Box box;
    box.R_OW = b.q_WO.toRotationMatrix().transpose();
    box.center = b.center_m;
    box.half = b.half_extents_m;
    box.axis_aligned = box.R_OW.isIdentity(0.0);
    box.lo = b.center_m - b.half_extents_m;
    box.hi = b.center_m + b.half_extents_m;
    boxes_.push_back(box);
  }
  for (const WorldCylinder& c : world.cylinders) {
    cylinders_.push_back(Cylinder{c.center_xy_m.x(), c.center_xy_m.y(), c.radius_m * c.radius_m,
                                  c.z_min_m, c.z_max_m});
  }
  for (const WorldMesh& m : world.meshes) {
    for (const Eigen::Vector3i& t : m.triangles) {
      const Eigen::Vector3d& a = m.vertices_W[static_cast<size_t>(t[0])];
      const Eigen::Vector3d& b = m.vertices_W[static_cast<size_t>(t[1])];
      const Eigen::Vector3d& c = m.vertices_W[static_cast<size_t>(t[2])];
      triangles_.push_back(Triangle{a, b - a, c - a});
    }
  }
  for (const WorldPlane& p : world.planes) planes_.push_back(Plane{p.normal, p.offset_m});
  num_finite_ = static_cast<int>(boxes_.size() + cylinders_.size() + triangles_.size());
  num_primitives_ = num_finite_ + static_cast<int>(planes_.size());
  if (num_finite_ == 0) return;

  // Bounds of every finite primitive, then the grid over their union.
  std::vector<Eigen::AlignedBox3d> bounds;
  for (const WorldBox& b : world.boxes) bounds.push_back(BoundsOf(b));
  for (const WorldCylinder& c : world.cylinders) bounds.push_back(BoundsOf(c));
  for (const Triangle& t : triangles_) {
    Eigen::AlignedBox3d b(t.v0);
    b.extend(t.v0 + t.e1);
    b.extend(t.v0 + t.e2);
    bounds.push_back(b);
  }
  // BVH over the bounds.
  std::vector<int> ids(static_cast<size_t>(num_finite_));
  for (int id = 0; id < num_finite_; ++id) ids[static_cast<size_t>(id)] = id;
  bvh_.reserve(2 * ids.size());
  BuildBvh(&ids, 0, num_finite_, bounds);
  if (accelerator_ != Accelerator::kGrid) return;

  Eigen::AlignedBox3d all;
  for (const auto& b : bounds) all.extend(b);
  grid_min_ = all.min().array() - 1e-9;
  const Eigen::Vector3d extent = (all.max() - grid_min_).array() + 1e-9;
  bin_m_ = std::max(bin_m, extent.maxCoeff() / kMaxBinsPerAxis);
  inv_bin_ = 1.0 / bin_m_;
  for (int a = 0; a < 3; ++a) {
    dims_[a] = std::max(1, static_cast<int>(std::ceil(extent[a] * inv_bin_)));
  }
  grid_max_ = grid_min_ + dims_.cast<double>() * bin_m_;

  const size_t num_bins = static_cast<size_t>(dims_.x()) * dims_.y() * dims_.z();
  std::vector<uint32_t> counts(num_bins + 1, 0);
  auto bin_range = [&](const Eigen::AlignedBox3d& b, Eigen::Vector3i* lo, Eigen::Vector3i* hi) {
    for (int a = 0; a < 3; ++a) {
      (*lo)[a] = std::clamp(static_cast<int>(std::floor((b.min()[a] - grid_min_[a]) * inv_bin_)), 0,
                            dims_[a] - 1);
      (*hi)[a] = std::clamp(static_cast<int>(std::floor((b.max()[a] - grid_min_[a]) * inv_bin_)), 0,
                            dims_[a] - 1);
    }
  };
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<uint32_t> fill;
    if (pass == 1) {
      bin_begin_.assign(num_bins + 1, 0);
      for (size_t i = 0; i < num_bins; ++i) bin_begin_[i + 1] = bin_begin_[i] + counts[i];
      bin_items_.assign(bin_begin_.back(), 0);
      fill.assign(bin_begin_.begin(), bin_begin_.end() - 1);
    }
    for (int id = 0; id < num_finite_; ++id) {
      Eigen::Vector3i lo, hi;
      bin_range(bounds[static_cast<size_t>(id)], &lo, &hi);
      for (int z = lo.z(); z <= hi.z(); ++z) {
        for (int y = lo.y(); y <= hi.y(); ++y) {
          for (int x = lo.x(); x <= hi.x(); ++x) {
            const size_t bin = static_cast<size_t>(x) +
                               static_cast<size_t>(dims_.x()) *
                                   (static_cast<size_t>(y) + static_cast<size_t>(dims_.y()) * z);
            if (pass == 0) {
              ++counts[bin];
            } else {
              bin_items_[fill[bin]++] = id;
            }
          }
        }
      }
    }
  }
}

void WorldRayCaster::TestPrimitive(int id, const Ray& ray, double* best, int* hit) const {
  double enter = -kInf;
  double exit = kInf;
  if (id < static_cast<int>(boxes_.size())) {
    const Box& b = boxes_[static_cast<size_t>(id)];
    if (b.axis_aligned) {
      // Slabs in W with the ray's precomputed reciprocals (see SlabBranchless).
      for (int a = 0; a < 3; ++a) {
        SlabBranchless(b.lo[a] - ray.o[a], b.hi[a] - ray.o[a], ray.inv[a], &enter, &exit);
      }
    } else {
      const Eigen::Vector3d o_O = b.R_OW * (ray.o - b.center);
      const Eigen::Vector3d u_O = b.R_OW * ray.u;
      for (int a = 0; a < 3; ++a) {
        double t0, t1;
        if (!Slab(o_O[a], u_O[a], -b.half[a], b.half[a], &t0, &t1)) return;
        enter = std::max(enter, t0);
        exit = std::min(exit, t1);
      }
    }
  } else if (id >= static_cast<int>(boxes_.size() + cylinders_.size())) {
    // Moller-Trumbore, two-sided, edges included.
    const Triangle& tri = triangles_[static_cast<size_t>(id) - boxes_.size() - cylinders_.size()];
    const Eigen::Vector3d p = ray.u.cross(tri.e2);
    const double det = tri.e1.dot(p);
    if (det == 0.0) return;  // parallel to the plane (a grazing ray misses a surface)
    const double inv_det = 1.0 / det;
    const Eigen::Vector3d s = ray.o - tri.v0;
    const double a = s.dot(p) * inv_det;
    if (a < 0.0 || a > 1.0) return;
    const Eigen::Vector3d q = s.cross(tri.e1);
    const double b = ray.u.dot(q) * inv_det;
    if (b < 0.0 || a + b > 1.0) return;
    const double t = tri.e2.dot(q) * inv_det;
    if (t < 0.0) return;
    if (t < *best) {
      *best = t;
      *hit = id;
    }
    return;
  } else {
    const Eigen::Vector3d& o = ray.o;
    const Eigen::Vector3d& u = ray.u;
    const Cylinder& c = cylinders_[static_cast<size_t>(id) - boxes_.size()];
    double t0, t1;
    if (!Slab(o.z(), u.z(), c.z_min, c.z_max, &t0, &t1)) return;
    const double dx = o.x() - c.cx;
    const double dy = o.y() - c.cy;
    const double a = u.x() * u.x() + u.y() * u.y();
    const double cc = dx * dx + dy * dy - c.r2;
    if (a == 0.0) {
      if (cc > 0.0) return;
      enter = t0;
      exit = t1;
    } else {
      const double b = dx * u.x() + dy * u.y();  // half of the linear coefficient
      const double disc = b * b - a * cc;
      if (disc < 0.0) return;
      // Numerically stable roots of a t^2 + 2 b t + cc = 0.
      const double q = -(b + std::copysign(std::sqrt(disc), b));
      double s0 = q / a;
      double s1 = q != 0.0 ? cc / q : s0;
      if (s0 > s1) std::swap(s0, s1);
      enter = std::max(t0, s0);
      exit = std::min(t1, s1);
    }
  }
  if (exit < enter || exit < 0.0) return;
  const double t = std::max(enter, 0.0);
  if (t < *best) {
    *best = t;
    *hit = id;
  }
}

void WorldRayCaster::TestPlanes(const Eigen::Vector3d& o, const Eigen::Vector3d& u, double* best,
                                int* hit) const {
  for (size_t i = 0; i < planes_.size(); ++i) {
    const Plane& p = planes_[i];
    const double height = p.normal.dot(o) - p.offset;
    double t;
    if (height <= 0.0) {
      t = 0.0;
    } else {
      const double rate = p.normal.dot(u);
      if (!(rate < 0.0)) continue;
      t = -height / rate;
    }
    if (t < *best) {
      *best = t;
      *hit = num_finite_ + static_cast<int>(i);
    }
  }
}

double WorldRayCaster::CastRayBruteForce(const Eigen::Vector3d& o_W, const Eigen::Vector3d& u_W,
                                         double max_range_m, int* primitive) const {
  double best = kInf;
  int hit = kNoHit;
  TestPlanes(o_W, u_W, &best, &hit);
  const Ray ray{o_W, u_W, u_W.cwiseInverse()};
  for (int id = 0; id < num_finite_; ++id) TestPrimitive(id, ray, &best, &hit);
  if (best > max_range_m) {
    best = kInf;
    hit = kNoHit;
  }
  if (primitive != nullptr) *primitive = hit;
  return best;
}

int WorldRayCaster::BuildBvh(std::vector<int>* ids, int begin, int end,
                             const std::vector<Eigen::AlignedBox3d>& bounds) {
  constexpr int kLeafSize = 1;
  Eigen::AlignedBox3d box;
  for (int i = begin; i < end; ++i) {
    box.extend(bounds[static_cast<size_t>((*ids)[static_cast<size_t>(i)])]);
  }
  const int index = static_cast<int>(bvh_.size());
  bvh_.push_back(BvhNode{});
  for (int a = 0; a < 3; ++a) {
    bvh_[static_cast<size_t>(index)].lo[a] = box.min()[a];
    bvh_[static_cast<size_t>(index)].hi[a] = box.max()[a];
  }
  if (end - begin <= kLeafSize) {
    BvhNode& leaf = bvh_[static_cast<size_t>(index)];
    leaf.first = static_cast<int>(bvh_items_.size());
    leaf.count = end - begin;
    for (int i = begin; i < end; ++i) bvh_items_.push_back((*ids)[static_cast<size_t>(i)]);
    return index;
  }
  // Surface-area heuristic: over the three axes, sort by bounding-box centre and take the split
  // minimising area(left) * count(left) + area(right) * count(right) (exhaustive: worlds hold
  // tens to thousands of primitives).
  auto area = [](const Eigen::AlignedBox3d& b) {
    const Eigen::Vector3d d = b.sizes();
    return d.x() * d.y() + d.y() * d.z() + d.z() * d.x();
  };
  const int n = end - begin;
  double best_cost = std::numeric_limits<double>::infinity();
  int best_axis = 0;
  int best_split = n / 2;
  std::vector<int> order(ids->begin() + begin, ids->begin() + end);
  std::vector<double> right_area(static_cast<size_t>(n) + 1, 0.0);
  for (int axis = 0; axis < 3; ++axis) {
    std::sort(order.begin(), order.end(), [&](int a, int b) {
      const double ca = bounds[static_cast<size_t>(a)].center()[axis];
      const double cb = bounds[static_cast<size_t>(b)].center()[axis];
      return ca < cb || (ca == cb && a < b);
    });
    Eigen::AlignedBox3d acc;
    for (int i = n - 1; i >= 1; --i) {
      acc.extend(bounds[static_cast<size_t>(order[static_cast<size_t>(i)])]);
      right_area[static_cast<size_t>(i)] = area(acc);
    }
    acc.setEmpty();
    for (int i = 1; i < n; ++i) {  // left = order[0, i), right = order[i, n)
      acc.extend(bounds[static_cast<size_t>(order[static_cast<size_t>(i - 1)])]);
      const double cost = area(acc) * i + right_area[static_cast<size_t>(i)] * (n - i);
      if (cost < best_cost) {
        best_cost = cost;
        best_axis = axis;
        best_split = i;
      }
    }
  }
  std::sort(ids->begin() + begin, ids->begin() + end, [&](int a, int b) {
    const double ca = bounds[static_cast<size_t>(a)].center()[best_axis];
    const double cb = bounds[static_cast<size_t>(b)].center()[best_axis];
    return ca < cb || (ca == cb && a < b);
  });
  const int mid = begin + best_split;
  const int left = BuildBvh(ids, begin, mid, bounds);
  const int right = BuildBvh(ids, mid, end, bounds);
  bvh_[static_cast<size_t>(index)].first = left;
  bvh_[static_cast<size_t>(index)].count = 0;
  bvh_[static_cast<size_t>(index)].right = right;
  return index;
}

void WorldRayCaster::WalkBvh(const Ray& ray, double max_range_m, double* best, int* hit) const {
  // Entry distance of the ray into a node's box within [0, min(best, range)], or +inf.
  auto enter = [&](const BvhNode& n) -> double {
    double t0 = 0.0;
    double t1 = std::min(*best, max_range_m);
    for (int a = 0; a < 3; ++a) {
      SlabBranchless(n.lo[a] - ray.o[a], n.hi[a] - ray.o[a], ray.inv[a], &t0, &t1);
    }
    // NOLINTNEXTLINE(bugprone-narrowing-conversions): +inf, double to double (clang-tidy 14)
    return t0 <= t1 ? t0 : kInf;
  };
  const double t_root = enter(bvh_[0]);
  if (t_root == kInf) return;
  int stack[64];
  double stack_t[64];
  int top = 0;
  stack[top] = 0;
  stack_t[top++] = t_root;
  while (top > 0) {
    --top;
    if (stack_t[top] >= *best) continue;  // a nearer hit was found since it was pushed
    const BvhNode& n = bvh_[static_cast<size_t>(stack[top])];
    if (n.count > 0) {
      for (int k = 0; k < n.count; ++k) {
        TestPrimitive(bvh_items_[static_cast<size_t>(n.first) + static_cast<size_t>(k)], ray, best,
                      hit);
      }
      continue;
    }
    const double tl = enter(bvh_[static_cast<size_t>(n.first)]);
    const double tr = enter(bvh_[static_cast<size_t>(n.right)]);
    // Push the farther child first so the nearer one is tested first.
    auto push = [&](int node, double t) {
      if (t < kInf) {
        stack[top] = node;
        stack_t[top++] = t;
      }
    };
    if (tl <= tr) {
      push(n.right, tr);
      push(n.first, tl);
    } else {
      push(n.first, tl);
      push(n.right, tr);
    }
    KESTREL_ASSERT(top <= 62);
  }
}

void WorldRayCaster::WalkGrid(const Ray& ray, double max_range_m, double* best, int* hit) const {
  const Eigen::Vector3d& o_W = ray.o;
  const Eigen::Vector3d& u_W = ray.u;
  // Clip [0, min(max_range, best)] to the grid box.
  double t_lo = 0.0;
  double t_hi = std::min(max_range_m, *best);
  for (int a = 0; a < 3; ++a) {
    double t0, t1;
    if (!Slab(o_W[a], u_W[a], grid_min_[a], grid_max_[a], &t0, &t1)) return;
    t_lo = std::max(t_lo, t0);
    t_hi = std::min(t_hi, t1);
  }
  if (t_lo > t_hi) return;
  // Amanatides & Woo walk over the bins from the entry point.
  const Eigen::Vector3d entry = o_W + t_lo * u_W;
  Eigen::Vector3i cell, step;
  Eigen::Vector3d t_max, t_delta;
  for (int a = 0; a < 3; ++a) {
    cell[a] = std::clamp(static_cast<int>(std::floor((entry[a] - grid_min_[a]) * inv_bin_)), 0,
                         dims_[a] - 1);
    if (u_W[a] > 0.0) {
      step[a] = 1;
      t_max[a] = (grid_min_[a] + (cell[a] + 1) * bin_m_ - o_W[a]) / u_W[a];
      t_delta[a] = bin_m_ / u_W[a];
    } else if (u_W[a] < 0.0) {
      step[a] = -1;
      t_max[a] = (grid_min_[a] + cell[a] * bin_m_ - o_W[a]) / u_W[a];
      t_delta[a] = -bin_m_ / u_W[a];
    } else {
      step[a] = 0;
      t_max[a] = kInf;
      t_delta[a] = kInf;
    }
  }
  const size_t stride_y = static_cast<size_t>(dims_.x());
  const size_t stride_z = stride_y * static_cast<size_t>(dims_.y());
  // Mailbox: primitives spanning several bins are tested once (the answer is the same).
  constexpr int kMailbox = 8;
  int32_t recent[kMailbox] = {-1, -1, -1, -1, -1, -1, -1, -1};
  int next_slot = 0;
  while (true) {
    const size_t bin = static_cast<size_t>(cell.x()) + stride_y * cell.y() + stride_z * cell.z();
    for (uint32_t k = bin_begin_[bin]; k < bin_begin_[bin + 1]; ++k) {
      const int32_t id = bin_items_[k];
      bool seen = false;
      for (int m = 0; m < kMailbox; ++m) seen |= recent[m] == id;
      if (seen) continue;
      recent[next_slot] = id;
      next_slot = (next_slot + 1) % kMailbox;
      TestPrimitive(id, ray, best, hit);
    }
    int axis = 0;
    if (t_max[1] < t_max[axis]) axis = 1;
    if (t_max[2] < t_max[axis]) axis = 2;
    const double t_exit = t_max[axis];
    if (*best <= t_exit || t_exit > t_hi) break;
    cell[axis] += step[axis];
    if (cell[axis] < 0 || cell[axis] >= dims_[axis]) break;
    t_max[axis] += t_delta[axis];
  }
}

double WorldRayCaster::CastRay(const Eigen::Vector3d& o_W, const Eigen::Vector3d& u_W,
                               double max_range_m, int* primitive, int hint) const {
  KESTREL_ASSERT(std::abs(u_W.squaredNorm() - 1.0) < 1e-9);
  double best = kInf;
  int hit = kNoHit;
  TestPlanes(o_W, u_W, &best, &hit);
  if (num_finite_ > 0) {
    const Ray ray{o_W, u_W, u_W.cwiseInverse()};
    if (hint >= 0 && hint < num_finite_) TestPrimitive(hint, ray, &best, &hit);
    if (accelerator_ == Accelerator::kBvh) {
      WalkBvh(ray, max_range_m, &best, &hit);
    } else {
      WalkGrid(ray, max_range_m, &best, &hit);
    }
  }
  if (best > max_range_m) {
    best = kInf;
    hit = kNoHit;
  }
  if (primitive != nullptr) *primitive = hit;
  return best;
}

void WorldRayCaster::CastRays(const Eigen::Vector3d& o_W, const std::vector<Eigen::Vector3d>& u_W,
                              double max_range_m, std::vector<double>* out_m,
                              int num_threads) const {
  out_m->resize(u_W.size());
  const size_t n = u_W.size();
  auto work = [&](size_t begin, size_t end) {
    int hit = kNoHit;
    for (size_t i = begin; i < end; ++i) (*out_m)[i] = CastRay(o_W, u_W[i], max_range_m, &hit, hit);
  };
  const size_t threads = std::min<size_t>(std::max(1, num_threads), std::max<size_t>(1, n / 1024));
  if (threads <= 1) {
    work(0, n);
    return;
  }
  std::vector<std::thread> pool;
  const size_t chunk = (n + threads - 1) / threads;
  for (size_t t = 1; t < threads; ++t) {
    pool.emplace_back(work, std::min(n, t * chunk), std::min(n, (t + 1) * chunk));
  }
  work(0, std::min(n, chunk));
  for (std::thread& th : pool) th.join();
}

}  // namespace kestrel
