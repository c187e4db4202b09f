#pragma once
/// @file
/// Integrates depth images, planar scans and single readings into an occupancy map
/// (docs/algorithms.md §2-§4), the way OctoMap's computeUpdate stands apart from its tree: the
/// integrator turns readings into rays, casts them in batches of eight (RayCaster::CastBatch),
/// evaluates their forward models together (OccupancyUpdater::PrecomputeBatch), on this thread
/// or on its one worker thread, and hands each batch to the map (OccupancyMap::UpdateRays),
/// which updates the rays one after the other, in order. Neither step before the map reads it,
/// so the map is the one ray-by-ray updates give, bit for bit, whatever the thread count or
/// instruction set (tests/mapping/occupancy_map_test.cc). It owns the instruction-set choice:
/// one table of kernels (mapping/kernels/kernels.h), picked at construction.
///
/// Order is fixed, so the same inputs give a bit-identical map: images row-major (v outer, u
/// inner), scans in ascending angle, one ray fully applied before the next. No allocation per
/// ray (the scratch is sized at construction from the map's max_range_m).

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include "common/se3.h"
#include "mapping/occupancy_map.h"
#include "mapping/range_bands.h"
#include "mapping/ray_batch_pipeline.h"
#include "mapping/ray_caster.h"
#include "mapping/sensor_model.h"

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

/// One sensor ray as the integrator sees it: from origin_W along the unit direction_W, with the
/// reading classified by the sensor model (docs/algorithms.md §3.4).
struct SensorRay {
  Eigen::Vector3d origin_W{Eigen::Vector3d::Zero()};
  Eigen::Vector3d direction_W{Eigen::Vector3d::UnitX()};
  Reading reading;
};

/// Ray of depth pixel (u, v) with raw count `raw` (0: no return where the model's
/// no_return_informs, else invalid: docs/algorithms.md §3.4): the pixel's direction
/// ((u - cx)/fx, (v - cy)/fy, 1) normalised and rotated by R_WS; the depth raw * depth_scale_m is
/// along the optical axis, so the range along the ray is that times |((u - cx)/fx, ...)|. The one
/// definition IntegrateDepthImage applies.
[[nodiscard]] SensorRay DepthPixelRay(const Pose3& X_WS, const Eigen::Matrix3d& R_WS,
                                      const DepthIntrinsics& in, int u, int v, uint16_t raw,
                                      double depth_scale_m, const SensorModel& model);
/// Ray of planar-scan beam i: angle angle_min_rad + i * angle_step_rad about z of S, reading
/// ranges_m[i] classified. The one definition IntegratePlanarScan applies.
[[nodiscard]] SensorRay PlanarBeamRay(const Pose3& X_WS, const Eigen::Matrix3d& R_WS,
                                      double angle_min_rad, double angle_step_rad, int i,
                                      float range_m, const SensorModel& model);

/// How a ScanIntegrator casts rays.
struct ScanIntegratorOptions {
  /// Casts on a worker thread ahead of the updates (ScanIntegrator::SetWorkerThread).
  bool worker_thread{false};
  /// The kernels: "" for the widest this CPU runs (or those the environment variable KESTREL_ISA
  /// names), "scalar", or a Highway target's name in lower case that this CPU runs ("sse4",
  /// "avx2", "avx3" = "avx512", "neon", "sve", ...; SupportedInstructionSets()). The map is the
  /// same bit for bit with each.
  std::string instruction_set;
};

/// Turns readings into cast rays for one map (not owned; it must outlive the integrator).
/// Not thread-safe; one per map.
class ScanIntegrator {
 public:
  /// How rays are cast.
  using Options = ScanIntegratorOptions;

  /// An integrator into `map`.
  /// @throws std::invalid_argument if map is null or the instruction set (Options, or
  /// KESTREL_ISA for "") is not one this CPU runs (the message lists those it runs).
  explicit ScanIntegrator(DenseOccupancyMap* map, const Options& options = Options());
  explicit ScanIntegrator(GrowingOccupancyMap* map, const Options& options = Options());
  ~ScanIntegrator();
  ScanIntegrator(const ScanIntegrator&) = delete;
  ScanIntegrator& operator=(const ScanIntegrator&) = delete;

  /// Applies one reading along a ray from origin_W along unit direction_W (W frame): classifies
  /// `range_m` with the sensor model (mapping/sensor_model.h), drops invalid readings (returns
  /// them counted in rays_invalid), casts the ray and updates its cells.
  /// @throws std::invalid_argument if direction_W is not unit, origin not finite, or the
  /// sensor's z_max exceeds the map's max_range_m.
  ScanStats IntegrateRay(const Eigen::Vector3d& origin_W, const Eigen::Vector3d& direction_W,
                         double range_m, const SensorModel& model);

  /// Same with an already classified reading (kInvalid is counted and dropped).
  ScanStats IntegrateReading(const Eigen::Vector3d& origin_W, const Eigen::Vector3d& direction_W,
                             const Reading& reading, const SensorModel& model);

  /// Applies a depth image, row-major. depth[v * width + u] * depth_scale_m is the depth along
  /// the optical axis (m), converted to the range along the pixel's ray; 0 means "no return"
  /// where the model's no_return_informs, and is dropped as invalid otherwise (DepthPixelRay).
  /// With the model's direction_uncertainty_rad above 0 each reading gets its range band from
  /// the pixels within that angle (mapping/range_bands.h; docs/algorithms.md §3.8).
  /// X_WS is the pose of the optical frame S in W.
  /// @throws std::invalid_argument on non-positive sizes (or more than 2^30 pixels), fx/fy/scale
  /// not positive and finite, a non-finite pose or |q| outside (0.5, 1.5).
  ScanStats IntegrateDepthImage(const Pose3& X_WS, const DepthIntrinsics& intrinsics,
                                const uint16_t* depth, int width, int height, double depth_scale_m,
                                const SensorModel& model);

  /// Applies a planar scan in ascending angle: beam i looks along angle_min_rad + i *
  /// angle_step_rad about z of the LIDAR frame S (x forward, z up); ranges_m[i] is classified by
  /// the model (+inf or >= z_max: no return; NaN, negative, < z_min: invalid); range bands from
  /// the beams within the model's direction_uncertainty_rad, as for depth images.
  /// @throws std::invalid_argument unless angle_step_rad > 0, the angles are finite, the pose is
  /// finite and |q| in (0.5, 1.5).
  ScanStats IntegratePlanarScan(const Pose3& X_WS, double angle_min_rad, double angle_step_rad,
                                const float* ranges_m, int count, const SensorModel& model);

  /// Casts the rays of IntegrateDepthImage and IntegratePlanarScan on a second thread, ahead of
  /// the updates, which stay in ray order: same map bit for bit. The worker casts batches and
  /// evaluates their forward models (mapping/ray_batch_pipeline.h). On a shared 2-vCPU machine
  /// its gain comes and goes in spells, down to below one thread's rate (each ray's data crosses
  /// the cores, and what that costs depends on where the host places the vCPUs; docs/STATUS.md,
  /// "Mapping"); so each kind of scan (depth images, planar scans) goes through the worker only
  /// while that has been the faster way (WorkerChoice, re-tried every 16th scan). Off by default
  /// (kestrel-mapper: MapperConfig::traversal_thread); enabling creates the worker once.
  void SetWorkerThread(bool enabled);
  /// Whether a worker thread is in use.
  [[nodiscard]] bool worker_thread() const { return pipeline_ != nullptr; }
  /// Name of the instruction set the kernels are compiled for ("scalar", "sse4", "avx2",
  /// "avx3", "neon", ...).
  [[nodiscard]] const char* instruction_set() const;
  /// The instruction sets this CPU runs, scalar first, then from the narrowest vectors to the
  /// widest (Options::instruction_set).
  [[nodiscard]] static std::vector<std::string> SupportedInstructionSets();
  /// The name of the instruction set Options::instruction_set = `name` selects ("" and
  /// KESTREL_ISA resolved, "avx512" = "avx3").
  /// @throws std::invalid_argument, listing the instruction sets this CPU runs, if it runs no
  /// such instruction set.
  [[nodiscard]] static std::string ResolveInstructionSet(const std::string& name);

 private:
  // What IntegrateRays applies (the worker's choice is kept per kind).
  enum ScanKind : int { kDepthImage = 0, kPlanarScan = 1, kSingleRay = 2 };
  ScanIntegrator(std::variant<DenseOccupancyMap*, GrowingOccupancyMap*> map,
                 const Options& options);
  // Applies rays 0..count-1 from origin_W described by source(i, &spec), batched, on the worker
  // or here (defined and used in scan_integrator.cc only).
  template <class Source>
  ScanStats IntegrateRays(ScanKind kind, const Eigen::Vector3d& origin_W, int count,
                          const Source& source, const SensorModel& model);
  template <class Map, class Source>
  ScanStats IntegrateRaysInto(Map* map, ScanKind kind, const Eigen::Vector3d& origin_W, int count,
                              const Source& source, const SensorModel& model);

  std::variant<DenseOccupancyMap*, GrowingOccupancyMap*> map_;
  const kernels::Kernels* kernels_;
  RayBatch batch_;
  WorkerChoice choices_[2];                     // per ScanKind of scans: with the worker or not
  std::unique_ptr<RayBatchPipeline> pipeline_;  // the worker thread
  // Range bands (mapping/range_bands.h), per sample of the current image or scan.
  std::vector<double> band_range_, band_nearest_, band_scratch_;
};

}  // namespace kestrel
