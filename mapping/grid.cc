#include "mapping/grid.h"

#include <cmath>

#include "common/check.h"

namespace kestrel {

void MapLimits::Validate() const {
  KESTREL_THROW_UNLESS(std::isfinite(resolution_m) && resolution_m > 0.0,
                       "map resolution_m = " << resolution_m << ", accepted (0, inf)");
  for (int axis = 0; axis < 3; ++axis) {
    KESTREL_THROW_UNLESS(
        std::isfinite(min_m[axis]) && std::isfinite(max_m[axis]) && max_m[axis] > min_m[axis],
        "map limits axis " << axis << ": min_m = " << min_m[axis] << ", max_m = " << max_m[axis]
                           << ", accepted finite with max > min");
    const double cells = std::ceil((max_m[axis] - min_m[axis]) / resolution_m);
    KESTREL_THROW_UNLESS(cells < double{1 << 20}, "map limits axis " << axis << " give " << cells
                                                                     << " cells, accepted < 2^20");
  }
}

void OccupancyLimits::Validate() const {
  KESTREL_THROW_UNLESS(p_min > 0.0 && p_min < 0.5, "p_min = " << p_min << ", accepted (0, 0.5)");
  KESTREL_THROW_UNLESS(p_init >= p_min && p_init <= 1.0 - p_min,
                       "p_init = " << p_init << ", accepted [p_min, 1 - p_min] = [" << p_min << ", "
                                   << 1.0 - p_min << "]");
}

GridGeometry GridGeometry::Fixed(const MapLimits& limits) {
  limits.Validate();
  GridGeometry g;
  g.origin_m_ = limits.min_m;
  g.resolution_m_ = limits.resolution_m;
  g.inv_resolution_ = 1.0 / limits.resolution_m;
  g.bounded_ = true;
  for (int axis = 0; axis < 3; ++axis) {
    // docs/algorithms.md §1.1: ceil((max - min)/alpha) cells, the upper limit rounds up.
    g.upper_[axis] = static_cast<int32_t>(
        std::ceil((limits.max_m[axis] - limits.min_m[axis]) / limits.resolution_m));
  }
  return g;
}

GridGeometry GridGeometry::Unbounded(const Eigen::Vector3d& origin_m, double resolution_m) {
  KESTREL_THROW_UNLESS(std::isfinite(resolution_m) && resolution_m > 0.0,
                       "resolution_m = " << resolution_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(origin_m.allFinite(), "grid origin_m must be finite");
  GridGeometry g;
  g.origin_m_ = origin_m;
  g.resolution_m_ = resolution_m;
  g.inv_resolution_ = 1.0 / resolution_m;
  g.bounded_ = false;
  g.lower_ = {-kUnboundedCells + 1, -kUnboundedCells + 1, -kUnboundedCells + 1};
  g.upper_ = {kUnboundedCells, kUnboundedCells, kUnboundedCells};
  return g;
}

GridGeometry GridGeometry::WithBounds(const CellIndex& lower, const CellIndex& upper) const {
  KESTREL_THROW_UNLESS(lower.x < upper.x && lower.y < upper.y && lower.z < upper.z,
                       "grid window: lower bounds must lie below the upper ones");
  GridGeometry g = *this;
  g.bounded_ = true;
  g.lower_ = lower;
  g.upper_ = upper;
  return g;
}

int64_t GridGeometry::AxisIndexOf(int axis, double v) const {
  int64_t i = static_cast<int64_t>(std::floor((v - origin_m_[axis]) * inv_resolution_));
  // The product may round across a boundary; settle it against Boundary() itself so that the
  // cell of a point and the boundaries the ray caster crosses can never disagree.
  while (v < Boundary(axis, i)) --i;
  while (v >= Boundary(axis, i + 1)) ++i;
  return i;
}

std::optional<CellIndex> GridGeometry::CellOf(const Eigen::Vector3d& point_W) const {
  if (!point_W.allFinite()) return std::nullopt;
  CellIndex c;
  for (int axis = 0; axis < 3; ++axis) {
    const double scaled = (point_W[axis] - origin_m_[axis]) * inv_resolution_;
    if (!(scaled > lower_[axis] - 2.0 && scaled < upper_[axis] + 2.0)) return std::nullopt;
    const int64_t i = AxisIndexOf(axis, point_W[axis]);
    if (i < lower_[axis] || i >= upper_[axis]) return std::nullopt;
    c[axis] = static_cast<int32_t>(i);
  }
  return c;
}

Eigen::Vector3d GridGeometry::CenterOf(const CellIndex& cell) const {
  return Eigen::Vector3d(origin_m_.x() + (cell.x + 0.5) * resolution_m_,
                         origin_m_.y() + (cell.y + 0.5) * resolution_m_,
                         origin_m_.z() + (cell.z + 0.5) * resolution_m_);
}

DenseGrid::DenseGrid(const MapLimits& limits, float initial_value)
    : geometry_(GridGeometry::Fixed(limits)), initial_value_(initial_value) {
  const CellIndex& d = geometry_.upper();
  values_.assign(static_cast<size_t>(d.x) * static_cast<size_t>(d.y) * static_cast<size_t>(d.z),
                 initial_value);
}

GrowingGrid::GrowingGrid(const Eigen::Vector3d& origin_m, double resolution_m, float initial_value)
    : geometry_(GridGeometry::Unbounded(origin_m, resolution_m)), initial_value_(initial_value) {}

CellIndex GrowingGrid::BlockOriginOf(uint64_t key) {
  const auto unpart = [](uint64_t bits) {
    return static_cast<int32_t>((static_cast<int64_t>(bits & 0x1FFFFFu) - (1 << 20)) * kBlockEdge);
  };
  return CellIndex{unpart(key), unpart(key >> 21), unpart(key >> 42)};
}

GrowingGrid::Block* GrowingGrid::CreateBlock(uint64_t key, uint32_t* index) {
  KESTREL_DEMAND(blocks_.size() < size_t{0xFFFFFFFFu});
  auto block = std::make_unique<Block>();
  std::fill(std::begin(block->values), std::end(block->values), initial_value_);
  Block* raw = block.get();
  *index = static_cast<uint32_t>(blocks_.size());
  index_of_.emplace(key, *index);
  blocks_.push_back(std::move(block));
  keys_.push_back(key);
  return raw;
}

GrowingGrid::Block* GrowingGrid::FindOrCreateBlock(const CellIndex& block_origin, uint32_t* index) {
  const uint64_t key = BlockKeyOf(block_origin);
  const auto it = index_of_.find(key);
  uint32_t created;
  if (index == nullptr) index = &created;
  if (it == index_of_.end()) return CreateBlock(key, index);
  *index = it->second;
  return blocks_[it->second].get();
}

float GrowingGrid::Get(const CellIndex& c) const {
  const auto it = index_of_.find(BlockKeyOf(c));
  return it == index_of_.end() ? initial_value_ : blocks_[it->second]->values[OffsetInBlock(c)];
}

void GrowingGrid::Set(const CellIndex& c, float value) {
  FindOrCreateBlock(c)->values[OffsetInBlock(c)] = value;
}

size_t GrowingGrid::memory_bytes() const {
  // Block payload plus an estimate of one hash node (key, pointer, next) and one bucket each.
  return blocks_.size() * (sizeof(Block) + 6 * sizeof(void*)) +
         index_of_.bucket_count() * sizeof(void*);
}

}  // namespace kestrel
