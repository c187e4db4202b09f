#include "mapping/range_bands.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/check.h"

namespace kestrel {

int BandWindowHalfWidth(double delta_rad, double samples_per_rad) {
  KESTREL_THROW_UNLESS(
      std::isfinite(delta_rad) && delta_rad >= 0.0 && std::isfinite(samples_per_rad) &&
          samples_per_rad > 0.0,
      "BandWindowHalfWidth: delta_rad = " << delta_rad << ", samples_per_rad = " << samples_per_rad
                                          << ", accepted delta >= 0, spacing > 0");
  // The small allowance keeps a delta of exactly k samples at k (rounding of delta * spacing).
  return static_cast<int>(std::ceil(delta_rad * samples_per_rad - 1e-9));
}

void WindowMin(const double* range_m, int width, int height, int ku, int kv, double* nearest_m,
               std::vector<double>* scratch) {
  KESTREL_THROW_UNLESS(width >= 0 && height >= 0 && ku >= 0 && kv >= 0 && nearest_m != nullptr &&
                           scratch != nullptr && range_m != nullptr,
                       "WindowMin: width = " << width << ", height = " << height << ", ku = " << ku
                                             << ", kv = " << kv
                                             << ", accepted non-negative with data");
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const size_t w = static_cast<size_t>(width);
  scratch->resize(w * static_cast<size_t>(height));
  double* const row_min = scratch->data();
  // Along each row: columns u - ku .. u + ku (readings only; NaN never compares less).
  for (int v = 0; v < height; ++v) {
    const double* r = range_m + static_cast<size_t>(v) * w;
    for (int u = 0; u < width; ++u) {
      double m = kInf;
      for (int j = std::max(0, u - ku); j <= std::min(width - 1, u + ku); ++j) {
        if (r[j] < m) m = r[j];
      }
      row_min[static_cast<size_t>(u) + static_cast<size_t>(v) * w] = m;
    }
  }
  // Then along each column: rows v - kv .. v + kv of the row results.
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      double m = kInf;
      for (int j = std::max(0, v - kv); j <= std::min(height - 1, v + kv); ++j) {
        m = std::min(m, row_min[static_cast<size_t>(u) + static_cast<size_t>(j) * w]);
      }
      nearest_m[static_cast<size_t>(u) + static_cast<size_t>(v) * w] = m;
    }
  }
}

Reading WithRangeBand(const Reading& reading, double nearest_m, double z_max_m,
                      double surface_max_m) {
  Reading out = reading;
  if (reading.kind == ReadingKind::kReturn) {
    out.below_m = std::max(0.0, reading.z_m - nearest_m);
    out.surface_unknown = out.below_m > surface_max_m;
  } else if (reading.kind == ReadingKind::kNoReturn && nearest_m < z_max_m) {
    out = Reading{ReadingKind::kInvalid, 0.0};
  }
  return out;
}

double BandWindowAngle(double delta_rad, double samples_per_rad) {
  return BandWindowHalfWidth(delta_rad, samples_per_rad) / samples_per_rad;
}

Reading PredictedBandedReturn(const SensorModelConfig& model, double z_m, double cos_incidence) {
  const Reading plain{ReadingKind::kReturn, z_m};
  const double delta = model.direction_uncertainty_rad;
  if (!(delta > 0.0)) return plain;
  const double c = std::clamp(cos_incidence, 0.0, 1.0);
  const double phi = std::acos(c);
  const double nearest = z_m * c / std::cos(std::max(phi - delta, 0.0));
  return WithRangeBand(plain, nearest, model.z_max_m, model.band_surface_max_m);
}

}  // namespace kestrel
