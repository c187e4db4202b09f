#pragma once
/// @file
/// Eight lanes for the batched hot paths, where eight rays are worked on at once (ray casting,
/// RayCaster::CastBatch; the forward model, SensorModel::FillLikelihoods; the posterior stores,
/// ExactBayesUpdater::UpdateBatchLane): the lane count of a RayBatch's layout. The kernels that
/// work on the lanes, one set per instruction set, and their dispatch are internal to mapping/
/// (mapping/kernels/kernels.h).

namespace kestrel::lanes {

/// Rays per batch: one AVX-512 register of doubles.
constexpr int kLanes = 8;

}  // namespace kestrel::lanes
