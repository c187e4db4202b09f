#include "mapping/scan_integrator.h"

#include <chrono>
#include <cmath>
#include <functional>

#include "common/check.h"
#include "mapping/kernels/kernels.h"

namespace kestrel {

namespace {
using MapPointer = std::variant<DenseOccupancyMap*, GrowingOccupancyMap*>;

// `map`, checked not to be null.
MapPointer Checked(MapPointer map) {
  KESTREL_THROW_UNLESS(std::visit([](const auto* m) { return m != nullptr; }, map),
                       "ScanIntegrator: map must not be null");
  return map;
}
double MaxRangeOf(const MapPointer& map) {
  return std::visit([](const auto* m) { return m->max_range_m(); }, map);
}
double ResolutionOf(const MapPointer& map) {
  return std::visit([](const auto* m) { return m->grid().geometry().resolution_m(); }, map);
}
const OccupancyUpdater& UpdaterOf(const MapPointer& map) {
  return std::visit([](const auto* m) -> const OccupancyUpdater& { return m->updater(); }, map);
}
}  // namespace

ScanIntegrator::ScanIntegrator(DenseOccupancyMap* map, const Options& options)
    : ScanIntegrator(MapPointer(map), options) {}

ScanIntegrator::ScanIntegrator(GrowingOccupancyMap* map, const Options& options)
    : ScanIntegrator(MapPointer(map), options) {}

ScanIntegrator::ScanIntegrator(MapPointer map, const Options& options)
    : map_(Checked(map)),
      kernels_(&kernels::Named(options.instruction_set)),
      batch_(MaxRangeOf(map_), ResolutionOf(map_)) {
  SetWorkerThread(options.worker_thread);
}

ScanIntegrator::~ScanIntegrator() = default;

const char* ScanIntegrator::instruction_set() const { return kernels_->name; }

std::vector<std::string> ScanIntegrator::SupportedInstructionSets() {
  std::vector<std::string> out;
  for (const kernels::Kernels* k : kernels::Supported()) out.emplace_back(k->name);
  return out;
}

std::string ScanIntegrator::ResolveInstructionSet(const std::string& name) {
  return kernels::Named(name).name;
}

void ScanIntegrator::SetWorkerThread(bool enabled) {
  if (!enabled) {
    pipeline_.reset();
  } else if (pipeline_ == nullptr) {
    pipeline_ = std::make_unique<RayBatchPipeline>(MaxRangeOf(map_), ResolutionOf(map_));
  }
}

template <class Source>
ScanStats ScanIntegrator::IntegrateRays(ScanKind kind, const Eigen::Vector3d& origin_W, int count,
                                        const Source& source, const SensorModel& model) {
  return std::visit(
      [&](auto* map) { return IntegrateRaysInto(map, kind, origin_W, count, source, model); },
      map_);
}

template <class Map, class Source>
ScanStats ScanIntegrator::IntegrateRaysInto(Map* map, ScanKind kind,
                                            const Eigen::Vector3d& origin_W, int count,
                                            const Source& source, const SensorModel& model) {
  KESTREL_THROW_UNLESS(model.config().z_max_m <= map->max_range_m(),
                       "ScanIntegrator: sensor z_max_m = " << model.config().z_max_m
                                                           << " exceeds the map's max_range_m = "
                                                           << map->max_range_m());
  ScanStats stats;
  // Every ray of a scan starts at origin_W: one lattice for all (OccupancyMap::CastLattice).
  const RayCaster caster(map->CastLattice(origin_W));
  const OccupancyUpdater& updater = map->updater();
  const kernels::Kernels& kernels = *kernels_;
  // Casts a batch and evaluates its forward models: reads no map (the worker may do it).
  const auto prepare = [&](const RaySegment* segments, const Reading* readings, int lanes_used,
                           RayBatch* batch) {
    caster.CastBatch(segments, lanes_used, batch, kernels);
    updater.PrecomputeBatch(model, readings, kernels, batch);
  };
  // Updates the batch's rays in order, on this thread.
  const auto sink = [&](const Reading* readings, const RayBatch& batch, uint64_t invalid) {
    stats.rays_invalid += invalid;
    map->UpdateRays(readings, batch, model, kernels, &stats);
  };
  // With a worker, each kind of scan goes the way that has been faster (WorkerChoice).
  WorkerChoice* const choice =
      pipeline_ != nullptr && kind != kSingleRay ? &choices_[kind] : nullptr;
  const bool use_worker = choice != nullptr && choice->NextUsesWorker();
  const auto started = std::chrono::steady_clock::now();
  if (use_worker) {
    // std::function over reference wrappers: no allocation.
    pipeline_->Run(count, RayBatchPipeline::Source(std::cref(source)),
                   RayBatchPipeline::Prepare(std::cref(prepare)),
                   RayBatchPipeline::Sink(std::cref(sink)));
  } else {
    RayBatchPipeline::RunInline(count, source, prepare, sink, &batch_);
  }
  if (choice != nullptr) {
    choice->Record(
        use_worker, stats.rays_applied,
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
  }
  return stats;
}

ScanStats ScanIntegrator::IntegrateRay(const Eigen::Vector3d& origin_W,
                                       const Eigen::Vector3d& direction_W, double range_m,
                                       const SensorModel& model) {
  return IntegrateReading(origin_W, direction_W, model.Classify(range_m), model);
}

ScanStats ScanIntegrator::IntegrateReading(const Eigen::Vector3d& origin_W,
                                           const Eigen::Vector3d& direction_W,
                                           const Reading& reading, const SensorModel& model) {
  if (reading.kind == ReadingKind::kInvalid) {
    ScanStats stats;
    stats.rays_invalid = 1;
    return stats;
  }
  const double length_m = UpdaterOf(map_).CastLength(model, reading);
  const auto source = [&](int, RaySpec* spec) {
    spec->segment = RaySegment{origin_W, direction_W, length_m};
    spec->reading = reading;
  };
  return IntegrateRays(kSingleRay, origin_W, 1, source, model);
}

SensorRay DepthPixelRay(const Pose3& X_WS, const Eigen::Matrix3d& R_WS, const DepthIntrinsics& in,
                        int u, int v, uint16_t raw, double depth_scale_m,
                        const SensorModel& model) {
  const Eigen::Vector3d ray_S((u - in.cx) * (1.0 / in.fx), (v - in.cy) * (1.0 / in.fy), 1.0);
  const double norm = ray_S.norm();
  SensorRay ray;
  ray.origin_W = X_WS.p;
  ray.direction_W = R_WS * (ray_S / norm);
  // Depth is along the optical axis; the range along the pixel's ray is depth * |ray_S|. A 0 is
  // "no return" only where the model says such readings inform (docs/algorithms.md §3.4).
  if (raw != 0) {
    ray.reading = model.Classify(raw * depth_scale_m * norm);
  } else {
    ray.reading = Reading{
        model.config().no_return_informs ? ReadingKind::kNoReturn : ReadingKind::kInvalid, 0.0};
  }
  return ray;
}

SensorRay PlanarBeamRay(const Pose3& X_WS, const Eigen::Matrix3d& R_WS, double angle_min_rad,
                        double angle_step_rad, int i, float range_m, const SensorModel& model) {
  const double angle = angle_min_rad + i * angle_step_rad;
  SensorRay ray;
  ray.origin_W = X_WS.p;
  ray.direction_W = (R_WS * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0.0)).normalized();
  ray.reading = model.Classify(range_m);
  return ray;
}

ScanStats ScanIntegrator::IntegrateDepthImage(const Pose3& X_WS, const DepthIntrinsics& in,
                                              const uint16_t* depth, int width, int height,
                                              double depth_scale_m, const SensorModel& model) {
  KESTREL_THROW_UNLESS(depth != nullptr && width > 0 && height > 0 &&
                           int64_t{width} * int64_t{height} <= int64_t{1} << 30,
                       "IntegrateDepthImage: width = " << width << ", height = " << height
                                                       << ", accepted positive (at most 2^30 "
                                                          "pixels) with data");
  KESTREL_THROW_UNLESS(std::isfinite(in.fx) && in.fx > 0.0 && std::isfinite(in.fy) && in.fy > 0.0 &&
                           std::isfinite(in.cx) && std::isfinite(in.cy),
                       "IntegrateDepthImage: intrinsics fx = " << in.fx << ", fy = " << in.fy
                                                               << ", accepted positive and finite");
  KESTREL_THROW_UNLESS(
      std::isfinite(depth_scale_m) && depth_scale_m > 0.0,
      "IntegrateDepthImage: depth_scale_m = " << depth_scale_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      X_WS.p.allFinite() && X_WS.q.coeffs().allFinite() && std::abs(X_WS.q.norm() - 1.0) < 0.5,
      "IntegrateDepthImage: pose must be finite with |q| in (0.5, 1.5), |q| = " << X_WS.q.norm());
  const Eigen::Matrix3d R_WS = X_WS.q.normalized().toRotationMatrix();
  const OccupancyUpdater& updater = UpdaterOf(map_);
  // Range bands (docs/algorithms.md §3.8): the nearest range in each pixel's window of +-ku
  // columns and +-kv rows.
  const double delta = model.config().direction_uncertainty_rad;
  const bool bands = delta > 0.0;
  if (bands) {
    const size_t n = static_cast<size_t>(width) * static_cast<size_t>(height);
    band_range_.resize(n);
    band_nearest_.resize(n);
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        const size_t i = static_cast<size_t>(u) + static_cast<size_t>(v) * width;
        // The range DepthPixelRay gives, bit for bit (a pixel nearest in its window: no band).
        const double norm =
            Eigen::Vector3d((u - in.cx) * (1.0 / in.fx), (v - in.cy) * (1.0 / in.fy), 1.0).norm();
        band_range_[i] = depth[i] == 0 ? std::nan("") : depth[i] * depth_scale_m * norm;
      }
    }
    WindowMin(band_range_.data(), width, height, BandWindowHalfWidth(delta, in.fx),
              BandWindowHalfWidth(delta, in.fy), band_nearest_.data(), &band_scratch_);
  }
  // Row-major: ray i is pixel (u, v) = (i % width, i / width).
  const auto source = [&](int i, RaySpec* spec) {
    const int v = i / width;
    const int u = i - v * width;
    const SensorRay ray =
        DepthPixelRay(X_WS, R_WS, in, u, v, depth[static_cast<size_t>(i)], depth_scale_m, model);
    spec->segment.origin_W = ray.origin_W;
    spec->segment.direction_W = ray.direction_W;
    spec->reading = bands ? WithRangeBand(ray.reading, band_nearest_[static_cast<size_t>(i)],
                                          model.config().z_max_m, model.config().band_surface_max_m)
                          : ray.reading;
    if (spec->reading.kind != ReadingKind::kInvalid) {
      spec->segment.length_m = updater.CastLength(model, spec->reading);
    }
  };
  return IntegrateRays(kDepthImage, X_WS.p, width * height, source, model);
}

ScanStats ScanIntegrator::IntegratePlanarScan(const Pose3& X_WS, double angle_min_rad,
                                              double angle_step_rad, const float* ranges_m,
                                              int count, const SensorModel& model) {
  KESTREL_THROW_UNLESS(count >= 0 && (count == 0 || ranges_m != nullptr),
                       "IntegratePlanarScan: count = " << count << ", accepted >= 0 with data");
  KESTREL_THROW_UNLESS(
      std::isfinite(angle_min_rad) && std::isfinite(angle_step_rad) && angle_step_rad > 0.0,
      "IntegratePlanarScan: angle_min_rad = " << angle_min_rad << ", angle_step_rad = "
                                              << angle_step_rad << ", accepted finite, step > 0");
  KESTREL_THROW_UNLESS(
      X_WS.p.allFinite() && X_WS.q.coeffs().allFinite() && std::abs(X_WS.q.norm() - 1.0) < 0.5,
      "IntegratePlanarScan: pose must be finite with |q| in (0.5, 1.5), |q| = " << X_WS.q.norm());
  const Eigen::Matrix3d R_WS = X_WS.q.normalized().toRotationMatrix();
  const OccupancyUpdater& updater = UpdaterOf(map_);
  // Range bands (docs/algorithms.md §3.8): the nearest range within +-k beams.
  const double delta = model.config().direction_uncertainty_rad;
  const bool bands = delta > 0.0 && count > 0;
  if (bands) {
    band_range_.resize(static_cast<size_t>(count));
    band_nearest_.resize(static_cast<size_t>(count));
    for (int i = 0; i < count; ++i) {
      const double r = ranges_m[i];
      band_range_[static_cast<size_t>(i)] = r >= 0.0 ? r : std::nan("");  // NaN, negative: none
    }
    WindowMin(band_range_.data(), count, 1, BandWindowHalfWidth(delta, 1.0 / angle_step_rad), 0,
              band_nearest_.data(), &band_scratch_);
  }
  const auto source = [&](int i, RaySpec* spec) {
    const SensorRay ray =
        PlanarBeamRay(X_WS, R_WS, angle_min_rad, angle_step_rad, i, ranges_m[i], model);
    spec->segment.origin_W = ray.origin_W;
    spec->segment.direction_W = ray.direction_W;
    spec->reading = bands ? WithRangeBand(ray.reading, band_nearest_[static_cast<size_t>(i)],
                                          model.config().z_max_m, model.config().band_surface_max_m)
                          : ray.reading;
    if (spec->reading.kind != ReadingKind::kInvalid) {
      spec->segment.length_m = updater.CastLength(model, spec->reading);
    }
  };
  return IntegrateRays(kPlanarScan, X_WS.p, count, source, model);
}

}  // namespace kestrel
