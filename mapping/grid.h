#pragma once
/// @file
/// 3D occupancy grids (docs/algorithms.md §1.1): cubic cells of edge `resolution_m` aligned to the
/// lower map limit. Cell (i, j, k) spans [min + i*alpha, min + (i+1)*alpha) per axis (half-open),
/// and a fixed map holds ceil((max - min)/alpha) cells per axis, so the upper limit rounds up.
/// Two storages share that geometry and give identical numbers inside the common region:
///  - DenseGrid: the paper's fixed limits, one float per cell in one array (x fastest).
///  - GrowingGrid: unbounded, cells allocated in 8x8x8 blocks on first touch, found through a
///    hash map.
/// Cell values are plain floats; what they mean (a probability, a log-odds) belongs to the
/// updater that writes them (mapping/occupancy_map.h).

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <memory>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

namespace kestrel {

/// Integer index of a cell, per axis, counted from the lower map limit (may be negative in a
/// GrowingGrid). Not a metric point: convert with GridGeometry::CellOf / CenterOf.
struct CellIndex {
  int32_t x{0};  ///< cell index along world x
  int32_t y{0};  ///< cell index along world y
  int32_t z{0};  ///< cell index along world z

  [[nodiscard]] friend bool operator==(const CellIndex& a, const CellIndex& b) {
    return a.x == b.x && a.y == b.y && a.z == b.z;
  }
  [[nodiscard]] friend bool operator!=(const CellIndex& a, const CellIndex& b) { return !(a == b); }
  /// Component access, axis 0..2.
  [[nodiscard]] int32_t operator[](int axis) const { return axis == 0 ? x : (axis == 1 ? y : z); }
  /// Mutable component access, axis 0..2.
  [[nodiscard]] int32_t& operator[](int axis) { return axis == 0 ? x : (axis == 1 ? y : z); }
};

/// Map limits in the world frame W (z up). Cells are aligned to `min_m`.
struct MapLimits {
  Eigen::Vector3d min_m{-4.0, -6.0, -0.15};  ///< lower corner, m, W (paper simulation map)
  Eigen::Vector3d max_m{4.0, 6.0, 1.5};      ///< upper corner, m, W; rounded up to whole cells
  double resolution_m{0.075};                ///< cell edge alpha, m (paper: 0.075)

  /// @throws std::invalid_argument unless every value is finite, resolution_m > 0 and
  /// max_m > min_m on every axis.
  void Validate() const;
};

/// Parameters of the occupancy values every grid starts with and is clamped to.
struct OccupancyLimits {
  double p_init{0.1};  ///< P_init, prior of every cell before any reading (paper: 0.1)
  double p_min{1e-4};  ///< P_min: probabilities are clamped to [P_min, 1 - P_min] after updates

  /// @throws std::invalid_argument unless 0 < p_min < 0.5 and p_min <= p_init <= 1 - p_min.
  void Validate() const;
};

/// The lattice shared by every grid: origin (the lower limit), edge alpha, and optionally the
/// index bounds of a fixed map. Pure arithmetic, no storage.
class GridGeometry {
 public:
  /// Index bound used by unbounded (growing) grids: |index| < kUnboundedCells per axis.
  static constexpr int32_t kUnboundedCells = 1 << 23;

  /// Fixed map: cells [0, ceil((max - min)/alpha)) per axis.
  /// @throws std::invalid_argument if limits.Validate() throws.
  static GridGeometry Fixed(const MapLimits& limits);
  /// Unbounded lattice aligned to `origin_m` with edge `resolution_m`; indices are limited to
  /// (-kUnboundedCells, kUnboundedCells) so that index arithmetic cannot overflow.
  /// @throws std::invalid_argument unless resolution_m > 0 and origin_m is finite.
  static GridGeometry Unbounded(const Eigen::Vector3d& origin_m, double resolution_m);
  /// The same lattice (every point in the same cell) with the bounds [lower, upper) per axis: a
  /// window of it (OccupancyMap::CastLattice).
  /// @throws std::invalid_argument unless lower < upper on every axis.
  [[nodiscard]] GridGeometry WithBounds(const CellIndex& lower, const CellIndex& upper) const;

  /// Edge alpha of a cell, m.
  [[nodiscard]] double resolution_m() const { return resolution_m_; }
  /// Lower corner of cell (0,0,0), m, W.
  [[nodiscard]] const Eigen::Vector3d& origin_m() const { return origin_m_; }
  /// Smallest valid index per axis (0 for a fixed map).
  [[nodiscard]] const CellIndex& lower() const { return lower_; }
  /// One past the largest valid index per axis (the cell count for a fixed map).
  [[nodiscard]] const CellIndex& upper() const { return upper_; }
  /// Whether the grid has fixed limits (or is a window, WithBounds).
  [[nodiscard]] bool bounded() const { return bounded_; }
  /// Whether `other` is the same lattice with the same bounds (same cell of every point).
  [[nodiscard]] bool SameLattice(const GridGeometry& other) const {
    return origin_m_ == other.origin_m_ && resolution_m_ == other.resolution_m_ &&
           lower_ == other.lower_ && upper_ == other.upper_ && bounded_ == other.bounded_;
  }

  /// Lower boundary of cell `index` along `axis`: origin + index * alpha, m. Every comparison of a
  /// point with a cell boundary in Kestrel uses exactly this expression.
  [[nodiscard]] double Boundary(int axis, int64_t index) const {
    return origin_m_[axis] + static_cast<double>(index) * resolution_m_;
  }
  /// Cell index along `axis` of coordinate `v` (m): the i with Boundary(i) <= v < Boundary(i+1).
  /// Precondition: v finite and the result representable.
  [[nodiscard]] int64_t AxisIndexOf(int axis, double v) const;
  /// The cell containing point_W, or nullopt if it lies outside the bounds (or is not finite).
  [[nodiscard]] std::optional<CellIndex> CellOf(const Eigen::Vector3d& point_W) const;
  /// Centre of a cell, m, W (no bounds check).
  [[nodiscard]] Eigen::Vector3d CenterOf(const CellIndex& cell) const;
  /// Whether `cell` lies inside the bounds.
  [[nodiscard]] bool Contains(const CellIndex& cell) const {
    return cell.x >= lower_.x && cell.y >= lower_.y && cell.z >= lower_.z && cell.x < upper_.x &&
           cell.y < upper_.y && cell.z < upper_.z;
  }

 private:
  Eigen::Vector3d origin_m_{Eigen::Vector3d::Zero()};
  double resolution_m_{1.0};
  double inv_resolution_{1.0};
  CellIndex lower_;
  CellIndex upper_;
  bool bounded_{false};
};

/// The paper's fixed-limit grid: one float per cell, x fastest then y then z.
class DenseGrid {
 public:
  /// A grid over `limits` with every cell set to `initial_value`.
  /// @throws std::invalid_argument if limits.Validate() throws.
  DenseGrid(const MapLimits& limits, float initial_value);

  /// The lattice and bounds.
  [[nodiscard]] const GridGeometry& geometry() const { return geometry_; }
  /// Cells per axis.
  [[nodiscard]] const CellIndex& dims() const { return geometry_.upper(); }
  /// Number of cells.
  [[nodiscard]] size_t size() const { return values_.size(); }
  /// Value the grid was created with.
  [[nodiscard]] float initial_value() const { return initial_value_; }
  /// All cell values, x fastest.
  [[nodiscard]] const std::vector<float>& values() const { return values_; }
  /// Mutable cell values (for loading a saved map); the size must not change.
  [[nodiscard]] std::vector<float>& mutable_values() { return values_; }
  /// Linear index of an in-bounds cell.
  [[nodiscard]] size_t LinearIndexOf(const CellIndex& c) const {
    return static_cast<size_t>(c.x) +
           static_cast<size_t>(dims().x) *
               (static_cast<size_t>(c.y) +
                static_cast<size_t>(dims().y) * static_cast<size_t>(c.z));
  }
  /// Value of an in-bounds cell (precondition: geometry().Contains(c)).
  [[nodiscard]] float Get(const CellIndex& c) const { return values_[LinearIndexOf(c)]; }
  /// Pointer to the value of an in-bounds cell (stable for the grid's lifetime).
  [[nodiscard]] float* Find(const CellIndex& c) { return &values_[LinearIndexOf(c)]; }
  /// Sets the value of an in-bounds cell.
  void Set(const CellIndex& c, float value) { values_[LinearIndexOf(c)] = value; }
  /// Bytes of cell storage.
  [[nodiscard]] size_t memory_bytes() const { return values_.size() * sizeof(float); }

 private:
  GridGeometry geometry_;
  float initial_value_;
  std::vector<float> values_;
};

/// A grid without limits: cells aligned to `origin_m` (use the fixed map's lower limit to get
/// the same lattice), allocated in blocks of kBlockEdge^3 cells on first touch, each block
/// filled with the initial value. Memory is proportional to the space touched.
class GrowingGrid {
 public:
  /// log2 of the block edge in cells.
  static constexpr int kBlockShift = 3;
  /// Block edge in cells (8).
  static constexpr int kBlockEdge = 1 << kBlockShift;
  /// Cells per block (512).
  static constexpr int kBlockCells = kBlockEdge * kBlockEdge * kBlockEdge;

  /// One block: kBlockCells values, x fastest.
  struct Block {
    float values[kBlockCells];
  };

  /// An empty grid aligned to `origin_m` with edge `resolution_m`.
  /// @throws std::invalid_argument unless resolution_m > 0 and origin_m is finite.
  GrowingGrid(const Eigen::Vector3d& origin_m, double resolution_m, float initial_value);
  GrowingGrid(const GrowingGrid&) = delete;
  GrowingGrid& operator=(const GrowingGrid&) = delete;
  GrowingGrid(GrowingGrid&&) = default;
  GrowingGrid& operator=(GrowingGrid&&) = default;

  /// The (unbounded) lattice.
  [[nodiscard]] const GridGeometry& geometry() const { return geometry_; }
  /// Value every untouched cell has.
  [[nodiscard]] float initial_value() const { return initial_value_; }
  /// Value of a cell (the initial value if its block was never touched). Does not allocate.
  [[nodiscard]] float Get(const CellIndex& c) const;
  /// Sets the value of a cell, allocating its block if needed.
  void Set(const CellIndex& c, float value);
  /// Number of allocated blocks.
  [[nodiscard]] size_t block_count() const { return blocks_.size(); }
  /// The block created `index`-th (0 .. block_count()-1; creation order is deterministic for the
  /// same sequence of touches). Blocks are never freed or moved.
  [[nodiscard]] const Block& block(size_t index) const { return *blocks_[index]; }
  /// First cell of the block created `index`-th.
  [[nodiscard]] CellIndex block_origin(size_t index) const { return BlockOriginOf(keys_[index]); }
  /// Approximate bytes used: blocks plus hash-table nodes.
  [[nodiscard]] size_t memory_bytes() const;
  /// Calls f(block_origin_cell, const Block&) for every allocated block, in ascending key order
  /// (deterministic, for saving and hashing).
  template <class F>
  void ForEachBlock(F&& f) const {
    std::vector<std::pair<uint64_t, uint32_t>> order;
    order.reserve(blocks_.size());
    for (const auto& kv : index_of_) order.push_back(kv);
    std::sort(order.begin(), order.end());
    for (const auto& [key, index] : order) f(BlockOriginOf(key), *blocks_[index]);
  }
  /// The block holding `block_origin` (a multiple of kBlockEdge per axis), created if needed;
  /// its creation index (block()) goes to *index when index is not null.
  Block* FindOrCreateBlock(const CellIndex& block_origin, uint32_t* index = nullptr);

  /// Key of the block holding `c` (21 bits per axis, biased).
  [[nodiscard]] static uint64_t BlockKeyOf(const CellIndex& c) {
    const auto part = [](int32_t v) {
      return static_cast<uint64_t>((v >> kBlockShift) + (1 << 20)) & 0x1FFFFFu;
    };
    return part(c.x) | (part(c.y) << 21) | (part(c.z) << 42);
  }
  /// Offset of `c` inside its block.
  [[nodiscard]] static int OffsetInBlock(const CellIndex& c) {
    constexpr int kMask = kBlockEdge - 1;
    return (c.x & kMask) | ((c.y & kMask) << kBlockShift) | ((c.z & kMask) << (2 * kBlockShift));
  }
  /// First cell of the block with key `key`.
  [[nodiscard]] static CellIndex BlockOriginOf(uint64_t key);

 private:
  // Creates the block of `key` (not present yet); its creation index goes to *index.
  Block* CreateBlock(uint64_t key, uint32_t* index);

  GridGeometry geometry_;
  float initial_value_;
  std::unordered_map<uint64_t, uint32_t> index_of_;  // block key -> creation index
  std::vector<std::unique_ptr<Block>> blocks_;       // by creation index
  std::vector<uint64_t> keys_;                       // by creation index
};

}  // namespace kestrel
