#pragma once
/// @file
/// A 3D occupancy map that applies whole scans ray by ray (docs/algorithms.md §1-§5): a grid
/// (DenseGrid with the paper's fixed limits, or GrowingGrid), a ray caster over its lattice, and
/// an OccupancyUpdater (Kestrel's exact model or the log-odds baseline). The map entropy
/// H(map) = sum_i H(P(m_i)) (eqs. 5-6) is kept per block of 512 cells (the GrowingGrid's 8^3
/// blocks; runs of 512 consecutive cells of a DenseGrid's array, so a cell's block is its linear
/// index / 512): a ray marks the blocks of the cells it changed, and a query
/// recomputes the marked blocks' sums and adds all block sums in block order. The result is a
/// function of the cell values only (not of when it is queried), costs no logarithm per cell
/// update, and is O(changed blocks x 512 + blocks) per query; for a GrowingGrid it sums the
/// allocated cells (each new block adds 512 H(P_init)).
///
/// Order is fixed, so the same inputs give a bit-identical map: images row-major (v outer, u
/// inner), scans in ascending angle, one ray fully applied before the next. No allocation per
/// ray (the scratch is sized at construction from max_range_m); a GrowingGrid allocates a block
/// the first time a ray touches it.
///
/// Batches (DenseGrid, SetRayBatches): ApplyDepthImage and ApplyPlanarScan cast eight rays at
/// once in vector registers (RayCaster::CastBatch) and evaluate their forward models together
/// (OccupancyUpdater::PrecomputeBatch), on this thread or on the traversal thread, then update
/// the eight rays one after the other, in order. Neither step reads the map, so the map is the
/// one ray-by-ray updates give, bit for bit (tests/mapping/occupancy_map_test.cc).

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "common/se3.h"
#include "mapping/grid.h"
#include "mapping/occupancy_updater.h"
#include "mapping/ray_batch_pipeline.h"
#include "mapping/ray_caster.h"
#include "mapping/sensor_model.h"
#include "mapping/traversal_pipeline.h"

namespace kestrel {

/// Pinhole intrinsics of a depth camera, pixels. Pixel (u, v) (column, row; centres at integer
/// coordinates, OpenCV convention) looks along ((u - cx)/fx, (v - cy)/fy, 1) in the optical
/// frame S (z forward, x right, y down).
struct DepthIntrinsics {
  double fx{0.0};  ///< focal length along x, px
  double fy{0.0};  ///< focal length along y, px
  double cx{0.0};  ///< principal point x, px
  double cy{0.0};  ///< principal point y, px
};

/// What applying one scan did.
struct ScanStats {
  uint64_t rays_applied{0};    ///< returns and "no return" readings applied
  uint64_t rays_no_return{0};  ///< of which "no return"
  uint64_t rays_invalid{0};    ///< readings dropped as carrying no information
  uint64_t cells_updated{0};   ///< cell writes

  /// Adds another scan's counts.
  ScanStats& operator+=(const ScanStats& o) {
    rays_applied += o.rays_applied;
    rays_no_return += o.rays_no_return;
    rays_invalid += o.rays_invalid;
    cells_updated += o.cells_updated;
    return *this;
  }
};

/// The map over a grid type (DenseGrid or GrowingGrid). Neither copyable nor movable (scratch
/// pointers into the grid).
template <class Grid>
class OccupancyMap {
 public:
  /// A map over `grid` (whose cells should hold updater->initial_value()) whose sensors reach at
  /// most `max_range_m` (sizes the per-ray scratch).
  /// @throws std::invalid_argument if updater is null or max_range_m is not positive.
  OccupancyMap(Grid grid, std::unique_ptr<OccupancyUpdater> updater, double max_range_m);
  OccupancyMap(const OccupancyMap&) = delete;
  OccupancyMap& operator=(const OccupancyMap&) = delete;

  /// Applies one reading along a ray from origin_W along unit direction_W (W frame): classifies
  /// `range_m` with the sensor model (mapping/sensor_model.h), drops invalid readings (returns
  /// them counted in rays_invalid), casts the ray and updates its cells.
  /// @throws std::invalid_argument if direction_W is not unit, origin not finite, or the
  /// sensor's z_max exceeds max_range_m.
  ScanStats ApplyRay(const Eigen::Vector3d& origin_W, const Eigen::Vector3d& direction_W,
                     double range_m, const SensorModel& model);

  /// Same with an already classified reading (kInvalid is counted and dropped).
  ScanStats ApplyReading(const Eigen::Vector3d& origin_W, const Eigen::Vector3d& direction_W,
                         const Reading& reading, const SensorModel& model);

  /// Applies a depth image, row-major. depth[v * width + u] * depth_scale_m is the depth along
  /// the optical axis (m), converted to the range along the pixel's ray; 0 means "no return".
  /// X_WS is the pose of the optical frame S in W.
  /// @throws std::invalid_argument on non-positive sizes (or more than 2^30 pixels), fx/fy/scale
  /// not positive and finite, a non-finite pose or |q| outside (0.5, 1.5).
  ScanStats ApplyDepthImage(const Pose3& X_WS, const DepthIntrinsics& intrinsics,
                            const uint16_t* depth, int width, int height, double depth_scale_m,
                            const SensorModel& model);

  /// Applies a planar scan in ascending angle: beam i looks along angle_min_rad + i *
  /// angle_step_rad about z of the LIDAR frame S (x forward, z up); ranges_m[i] is classified by
  /// the model (+inf or >= z_max: no return; NaN, negative, < z_min: invalid).
  /// @throws std::invalid_argument unless angle_step_rad > 0, the angles are finite, the pose is
  /// finite and |q| in (0.5, 1.5).
  ScanStats ApplyPlanarScan(const Pose3& X_WS, double angle_min_rad, double angle_step_rad,
                            const float* ranges_m, int count, const SensorModel& model);

  /// H(map), nats, from the block sums (file comment); recomputes the blocks changed since the
  /// last query (so a const call writes a cache: not for concurrent calls).
  [[nodiscard]] double entropy_nats() const;
  /// H(map) recomputed from every cell (O(cells)), for tests and checks.
  [[nodiscard]] double RecomputeEntropy() const;
  /// Occupancy probability of a cell (the initial one for an untouched growing-grid cell).
  [[nodiscard]] double ProbabilityAt(const CellIndex& cell) const;
  /// FNV-1a hash of every stored cell value (bit patterns) in a deterministic order.
  [[nodiscard]] uint64_t Hash() const;
  /// The grid.
  [[nodiscard]] const Grid& grid() const { return grid_; }
  /// The grid, mutable (loading a map; call ResetEntropy() afterwards).
  [[nodiscard]] Grid& mutable_grid() { return grid_; }
  /// Marks every block for entropy recomputation (after cells were written through
  /// mutable_grid(), e.g. when loading a map).
  void ResetEntropy();
  /// The update rule.
  [[nodiscard]] const OccupancyUpdater& updater() const { return *updater_; }
  /// Longest ray the scratch holds, m.
  [[nodiscard]] double max_range_m() const { return ray_.max_length_m; }

  /// Casts the rays of ApplyDepthImage and ApplyPlanarScan on a second thread, ahead of the
  /// updates, which stay in ray order: same map bit for bit. With ray batches (SetRayBatches)
  /// the worker casts batches and evaluates their forward models (mapping/ray_batch_pipeline.h);
  /// otherwise it casts rays one by one and the two threads balance themselves
  /// (mapping/traversal_pipeline.h). On a shared 2-vCPU machine its gain comes and goes in spells,
  /// down to below one thread's rate (each ray's data crosses the cores, and what that costs
  /// depends on where the host places the vCPUs; docs/STATUS.md, "Mapping"); so with batches each
  /// kind of scan (depth images, planar scans) goes through the worker only while that has been the
  /// faster way (WorkerChoice, re-tried every 16th scan). Off by default (kestrel-mapper:
  /// MapperConfig::traversal_thread); enabling creates the worker once.
  void SetTraversalThread(bool enabled);
  /// Whether a traversal thread is in use.
  [[nodiscard]] bool traversal_thread() const {
    return pipeline_ != nullptr || batch_pipeline_ != nullptr;
  }

  /// Casts the rays of ApplyDepthImage and ApplyPlanarScan eight at a time, compiled for `isa`
  /// (file comment; DenseGrid only): same map bit for bit. Default: on where the CPU has
  /// AVX-512 (lanes::BestIsa), where it is faster than one ray at a time (measured:
  /// bench/mapping); the baseline kernels run the scalar code lane by lane, so elsewhere off.
  /// @throws std::invalid_argument if the CPU does not run `isa`.
  void SetRayBatches(bool enabled, lanes::Isa isa = lanes::BestIsa());
  /// Whether rays are cast in batches (SetRayBatches).
  [[nodiscard]] bool ray_batches() const { return batch_isa_.has_value(); }

 private:
  // What ApplyRays applies (the batch worker's choice is kept per kind).
  enum ScanKind : int { kDepthImage = 0, kPlanarScan = 1 };
  float* CellPointer(const CellIndex& c);
  // DenseGrid: the first cell value (nullptr for a GrowingGrid).
  float* DenseValues();
  // Entropy block of the k-th cell of the ray last passed to ApplyCastRay.
  uint32_t EntropyBlockOf(const RayCells& ray, int k) const;
  // DenseGrid: entropy block of the cell with linear index `linear` (file comment).
  static uint32_t DenseBlockOf(int64_t linear) {
    return static_cast<uint32_t>(linear >> kDenseBlockShift);
  }
  static constexpr int kDenseBlockShift = 9;  // 512 cells per DenseGrid entropy block
  // Sum of H over the cells of entropy block b.
  double BlockEntropy(uint32_t b) const;
  // Marks block b for recomputation.
  void MarkDirty(uint32_t b) const {
    if (block_dirty_[b] == 0) {
      block_dirty_[b] = 1;
      dirty_blocks_.push_back(b);
    }
  }
  // Grows the block arrays to the grid's block count (GrowingGrid), new blocks dirty.
  void SyncBlocks();
  // Updates the cells of an already cast ray; adds to *stats.
  void ApplyCastRay(const Reading& reading, const RayCells& ray, const SensorModel& model,
                    ScanStats* stats);
  // Applies rays 0..count-1 described by source(i, &spec), pipelined, batched or one by one
  // (defined and used in occupancy_map.cc only).
  template <class Source>
  ScanStats ApplyRays(ScanKind kind, int count, const Source& source, const SensorModel& model);
  // ApplyRays in batches of eight (file comment), from source(i, BatchRaySpec*).
  template <class Source>
  void ApplyRayBatches(int count, const Source& source, const SensorModel& model, ScanStats* stats);
  // Updates the rays of a cast batch in order; adds to *stats.
  void ApplyBatch(const Reading* readings, const RayBatch& batch, const SensorModel& model,
                  ScanStats* stats);
  // Whether ApplyRays casts in batches (a DenseGrid with batches on).
  [[nodiscard]] bool Batched() const;
  // Creates or drops the workers to match traversal_thread_ and the batches.
  void ConfigureWorkers();

  Grid grid_;
  std::unique_ptr<OccupancyUpdater> updater_;
  RayCaster caster_;
  RayCells ray_;
  RayBatch batch_;
  std::optional<lanes::Isa> batch_isa_;  // batches on, compiled for this instruction set
  std::vector<float*> cell_pointers_;
  std::vector<int> changed_;          // indices k of the cells the last ray changed
  std::vector<uint32_t> cell_block_;  // GrowingGrid: block index of each cell of the ray
  // Lazy entropy (file comment): per-block sums, dirty flags and list, cached total.
  mutable std::vector<double> block_entropy_;
  mutable std::vector<uint8_t> block_dirty_;
  mutable std::vector<uint32_t> dirty_blocks_;
  mutable double entropy_nats_{0.0};
  // GrowingGrid only: cached block access.
  std::unique_ptr<GrowingGrid::Accessor> accessor_;
  bool traversal_thread_{false};
  WorkerChoice choices_[2];  // per ScanKind: with the batch worker or without (ApplyRays)
  std::unique_ptr<TraversalPipeline> pipeline_;       // thread, rays one by one
  std::unique_ptr<RayBatchPipeline> batch_pipeline_;  // thread, batches
};

/// The paper's map: fixed limits, dense storage.
using DenseOccupancyMap = OccupancyMap<DenseGrid>;
/// A map that grows in 8^3 blocks.
using GrowingOccupancyMap = OccupancyMap<GrowingGrid>;

/// Kestrel's exact map over fixed limits (section 1 parameters, section 4 updates).
/// @throws std::invalid_argument on invalid limits.
std::unique_ptr<DenseOccupancyMap> MakeExactDenseMap(const MapLimits& limits,
                                                     const OccupancyLimits& occupancy,
                                                     double max_range_m);
/// Kestrel's exact map that grows, aligned to limits.min_m with limits.resolution_m.
std::unique_ptr<GrowingOccupancyMap> MakeExactGrowingMap(const MapLimits& limits,
                                                         const OccupancyLimits& occupancy,
                                                         double max_range_m);
/// The log-odds baseline over fixed limits.
std::unique_ptr<DenseOccupancyMap> MakeLogOddsDenseMap(const MapLimits& limits,
                                                       const LogOddsConfig& config,
                                                       double max_range_m);

}  // namespace kestrel
