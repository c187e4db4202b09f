#pragma once
/// @file
/// One ray's DDA walk (ray_caster.h, docs/algorithms.md §2.1), shared by RayCaster::Cast and the
/// batch kernels (kernels.h): the state after a ray's set-up (RayCaster::StartWalk), one step,
/// and the walk that stores each cell. Internal to mapping/.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>

#include "mapping/grid.h"
#include "mapping/lanes.h"
#include "mapping/ray_caster.h"

namespace kestrel {
namespace detail {

// One ray's DDA state after its set-up (RayCaster::StartWalk's comments explain each field).
struct RayWalk {
  int32_t cell[3];         // current cell
  int32_t step[3];         // +-1 or 0 per axis
  double inv_u[3];         // 1/u (+inf for an axis the ray runs along)
  double t_max[3];         // parameter of the next boundary crossing per axis
  double exit_index[3];    // index of that boundary, as a double
  double step_d[3];        // step as a double
  int32_t linear;          // x + nx (y + ny z) (bounded lattice)
  int32_t linear_step[3];  // change of linear per step of each axis
  double length;           // length clipped to where the ray leaves the bounds
  bool left_bounds;        // whether the bounds cut the ray
};

// Steps every axis whose boundary is crossed at t_axis (ties together: no zero-length cells).
// (A branch-free variant that recomputes every axis was slower: it puts the conversion and
// multiplications on the loop-carried dependency chain.)
template <bool kLinear>
[[gnu::always_inline]] inline void StepAxes(RayWalk* w, double t_axis,
                                            const Eigen::Vector3d& origin, double resolution,
                                            const Eigen::Vector3d& o) {
  for (int a = 0; a < 3; ++a) {
    if (w->t_max[a] <= t_axis) {  // == t_axis (the minimum); <= needs no NaN test
      w->cell[a] += w->step[a];
      if constexpr (kLinear) w->linear += w->linear_step[a];
      w->exit_index[a] += w->step_d[a];
      // (Boundary(a, c + exit_offset) - o) * (1/u), the same expression and value.
      w->t_max[a] = ((origin[a] + w->exit_index[a] * resolution) - o[a]) * w->inv_u[a];
    }
  }
}

// The next boundary crossing: min over the axes.
[[gnu::always_inline]] inline double NextCrossing(const RayWalk& w) {
  const double t_xy = w.t_max[0] < w.t_max[1] ? w.t_max[0] : w.t_max[1];
  return t_xy < w.t_max[2] ? t_xy : w.t_max[2];
}

}  // namespace detail

namespace detail {

// What WalkRay leaves: the cells stored, whether the ray goes on (kFirstCell), and t_in.
struct WalkEnd {
  int cells{0};
  bool walking{false};
  double t_in{0.0};
};

// The walk of one set-up ray *w (StartWalk): stores d_k at distance[n * stride], and the linear
// index (kLinear) and cell (kCells) likewise, for every cell with a positive-length chord, in
// order. The first cell is the only one whose chord can have zero length (the origin on a
// boundary, the ray pointing away): every later cell is entered at t_in < length and left at a
// strictly larger crossing (or at length), so the loop stores without testing. With kFirstCell
// it stops after the first stored cell, leaving *w and the returned t_in where the walk goes on
// (CastBatch continues it in vector lanes). The current cell's indices stay plain integers in
// registers (*w is a local of the caller): CellIndex's operator[] picks a member by reference,
// which kept the cell in memory, and storing it whole right after a one-member update stalled
// store-to-load forwarding on every step.
template <bool kLinear, bool kCells, bool kFirstCell = false>
[[gnu::always_inline]] inline WalkEnd WalkRay(RayWalk* w, const Eigen::Vector3d& o,
                                              const Eigen::Vector3d& origin, double resolution,
                                              ptrdiff_t stride, double* distance,
                                              int32_t* linear_out, CellIndex* cells) {
  const double length = w->length;
  ptrdiff_t at = 0;
  WalkEnd end;
  const auto store = [&](double t_out) {
    if constexpr (kCells) cells[at] = CellIndex{w->cell[0], w->cell[1], w->cell[2]};
    distance[at] = 0.5 * (end.t_in + t_out);  // docs/algorithms.md §2.2: d_k at the chord midpoint
    if constexpr (kLinear) linear_out[at] = w->linear;
    at += stride;
  };
  const auto step_axes = [&](double t_axis) {
    StepAxes<kLinear>(w, t_axis, origin, resolution, o);
    end.t_in = t_axis;
  };
  double t_axis = NextCrossing(*w);
  const double t_first = t_axis < length ? t_axis : length;
  if (t_first > end.t_in) store(t_first);  // positive-length chord only (file comment)
  if (t_axis < length) {
    step_axes(t_axis);
    end.walking = true;
    while (!kFirstCell || at == 0) {
      t_axis = NextCrossing(*w);
      if (t_axis >= length) {
        store(length);
        end.walking = false;
        break;
      }
      store(t_axis);
      step_axes(t_axis);
    }
  }
  end.cells = static_cast<int>(at / stride);
  return end;
}

// The lanes of a batch after their set-up and first cell (StartLanes), as arrays of eight: what
// the vector walks (ray_walk-inl.h) load into their registers.
struct LaneStart {
  alignas(64) double t_in[lanes::kLanes];
  alignas(64) double length[lanes::kLanes];
  alignas(64) double t_max[3][lanes::kLanes];
  alignas(64) double exit_index[3][lanes::kLanes];
  alignas(64) double step_d[3][lanes::kLanes];
  alignas(64) double inv_u[3][lanes::kLanes];
  alignas(64) double o[3][lanes::kLanes];
  alignas(64) double linear[lanes::kLanes];  // exact in a double below 2^53
  alignas(64) double linear_step[3][lanes::kLanes];
  unsigned active;  // lanes still walking (bit l)
};

// Each lane's first cell as WalkRay stores it (scalar, into the batch's layout: distance and
// linear_out at [l], size[l] = 0 or 1), and the lanes' state after it in *start: afterwards every
// lane in start->active has stored exactly one cell, in row 0, and goes on from row 1.
inline void StartLanes(const RaySegment* rays, int count, const bool* started, RayWalk* walks,
                       const Eigen::Vector3d& origin, double resolution, double* distance,
                       int32_t* linear_out, int32_t* size, LaneStart* start) {
  using lanes::kLanes;
  *start = LaneStart{};
  for (int l = 0; l < count; ++l) {
    if (!started[l]) continue;
    RayWalk& w = walks[l];
    const Eigen::Vector3d& o = rays[l].origin_W;
    const WalkEnd first = WalkRay<true, false, true>(&w, o, origin, resolution, kLanes,
                                                     distance + l, linear_out + l, nullptr);
    size[l] = first.cells;
    if (first.walking) start->active |= 1u << l;
    start->t_in[l] = first.t_in;
    start->length[l] = w.length;
    start->linear[l] = static_cast<double>(w.linear);
    for (int a = 0; a < 3; ++a) {
      start->t_max[a][l] = w.t_max[a];
      start->exit_index[a][l] = w.exit_index[a];
      start->step_d[a][l] = w.step_d[a];
      start->inv_u[a][l] = w.inv_u[a];
      start->o[a][l] = o[a];
      start->linear_step[a][l] = static_cast<double>(w.linear_step[a]);
    }
  }
}

}  // namespace detail

}  // namespace kestrel
