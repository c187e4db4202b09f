#pragma once
/// @file
/// Range bands (docs/algorithms.md §3.8): a ray whose direction is known only to an angle delta
/// may have met, along its believed direction, any surface that the rays within delta of it met.
/// So the first surface along the believed ray may lie as near as the nearest range read within
/// delta: a depth pixel's window of +-ceil(delta fx) columns and +-ceil(delta fy) rows, a planar
/// scan's +-ceil(delta / step) beams. Pure functions: the integrator (scan_integrator.h) calls
/// them per image or scan.

#include <limits>
#include <vector>

#include "mapping/sensor_model.h"

namespace kestrel {

/// The window's half-width in samples for an uncertainty of delta_rad at a spacing of
/// 1/samples_per_rad radians: ceil(delta * samples_per_rad), 0 for delta = 0.
/// @throws std::invalid_argument unless delta >= 0 and samples_per_rad > 0, both finite.
[[nodiscard]] int BandWindowHalfWidth(double delta_rad, double samples_per_rad);

/// The angle that window spans: BandWindowHalfWidth(delta_rad, samples_per_rad) /
/// samples_per_rad, at least delta_rad (whole samples). What the explorer's prediction of bands
/// uses as its delta (PredictedBandedReturn), for the sensor's spacing.
/// @throws std::invalid_argument as BandWindowHalfWidth.
[[nodiscard]] double BandWindowAngle(double delta_rad, double samples_per_rad);

/// For each sample i = u + width * v of a width x height image (height 1 for a scan) whose range
/// along its own ray is range_m[i] (NaN: no reading, skipped), the least range within columns
/// u +- ku and rows v +- kv: nearest_m[i] (+inf where the window holds no reading). `scratch` is
/// resized as needed (no allocation once large enough).
/// @throws std::invalid_argument on negative sizes or half-widths, or null pointers.
void WindowMin(const double* range_m, int width, int height, int ku, int kv, double* nearest_m,
               std::vector<double>* scratch);

/// The reading with its range band from the nearest range of its window (WindowMin):
///  - a return z gets below_m = z - nearest (at least 0), and is surface_unknown if that exceeds
///    surface_max_m (SensorModelConfig::band_surface_max_m);
///  - a no-return whose window holds a range nearer than z_max is invalid: along its believed
///    direction a surface may have been met, so "nothing up to z_max" cannot be told from it;
///  - anything else is returned as it is.
[[nodiscard]] Reading WithRangeBand(const Reading& reading, double nearest_m, double z_max_m,
                                    double surface_max_m = std::numeric_limits<double>::infinity());

/// The band a return at z_m would get if the ray met a plane whose normal makes the angle phi
/// with the ray, cos_incidence = |cos phi|, and every ray within the model's
/// direction_uncertainty_rad delta met that plane too (docs/algorithms.md §3.8, "Predicted
/// bands"): the nearest of them reads D / cos(max(phi - delta, 0)) with D = z cos phi, so
///     nearest = z cos phi / cos(max(phi - delta, 0)),
/// passed to WithRangeBand with the model's z_max and band_surface_max_m. For the explorer's
/// prediction of the mapper's update (its rays are not the sensor's pixels, so the window is
/// the angle, not a count of pixels). delta = 0: the plain return.
[[nodiscard]] Reading PredictedBandedReturn(const SensorModelConfig& model, double z_m,
                                            double cos_incidence);

}  // namespace kestrel
