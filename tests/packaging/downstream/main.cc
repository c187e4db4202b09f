// Uses an installed Kestrel: builds a small exact map, applies one depth reading along +x and
// checks the posterior (cells before the return cleared below the prior, the return's cell
// raised above it, a cell behind it untouched, the map entropy lowered), then round-trips an
// LCM message through the installed generated header. Exits 0 only if every check holds.
#include <cmath>
#include <cstdio>
#include <vector>

#include "kestrel/pose_t.hpp"
#include "mapping/occupancy_map.h"
#include "mapping/scan_integrator.h"
#include "mapping/sensor_model.h"

namespace {
int failures = 0;
void Check(bool ok, const char* what, double value) {
  std::printf("%s %s (%.6g)\n", ok ? "ok  " : "FAIL", what, value);
  if (!ok) ++failures;
}
}  // namespace

int main() {
  kestrel::MapLimits limits;
  limits.min_m = Eigen::Vector3d(-1.0, -1.0, 0.0);
  limits.max_m = Eigen::Vector3d(3.0, 1.0, 1.0);
  limits.resolution_m = 0.05;
  const kestrel::OccupancyLimits occupancy;  // P_init 0.1
  auto map = kestrel::MakeExactDenseMap(limits, occupancy, 4.0);
  const kestrel::SensorModel xtion(kestrel::SensorModelConfig::Xtion());
  const double h0 = map->entropy_nats();

  const Eigen::Vector3d origin(0.01, 0.02, 0.51);
  kestrel::ScanIntegrator integrator(map.get());
  const kestrel::ScanStats stats =
      integrator.IntegrateRay(origin, Eigen::Vector3d::UnitX(), 1.5, xtion);
  const kestrel::GridGeometry& g = map->grid().geometry();
  const double p_free = map->ProbabilityAt(*g.CellOf(origin + Eigen::Vector3d(0.7, 0, 0)));
  const double p_hit = map->ProbabilityAt(*g.CellOf(origin + Eigen::Vector3d(1.5, 0, 0)));
  const double p_behind = map->ProbabilityAt(*g.CellOf(origin + Eigen::Vector3d(2.8, 0, 0)));
  const double p_aside = map->ProbabilityAt(*g.CellOf(origin + Eigen::Vector3d(1.5, 0.5, 0)));

  Check(stats.rays_applied == 1, "one ray applied", static_cast<double>(stats.rays_applied));
  Check(stats.cells_updated > 20, "cells updated along the ray",
        static_cast<double>(stats.cells_updated));
  Check(p_free < 0.05, "P(free cell at 0.7 m) < 0.05", p_free);
  Check(p_hit > 0.1, "P(cell of the return at 1.5 m) > prior 0.1", p_hit);
  Check(std::abs(p_behind - 0.1) < 1e-6, "P(cell at 2.8 m, behind the return) = prior", p_behind);
  Check(std::abs(p_aside - 0.1) < 1e-6, "P(cell off the ray) = prior", p_aside);
  Check(map->entropy_nats() < h0, "map entropy lowered (nats)", h0 - map->entropy_nats());
  Check(std::abs(map->entropy_nats() - map->RecomputeEntropy()) < 1e-9 * h0,
        "kept entropy = recomputed", map->entropy_nats());

  kestrel::pose_t pose{};
  pose.utime = 123456789;
  pose.frame_id = "world";
  pose.child_frame_id = "kestrel";
  pose.position_m[2] = 0.51;
  std::vector<uint8_t> buffer(static_cast<size_t>(pose.getEncodedSize()));
  pose.encode(buffer.data(), 0, static_cast<int>(buffer.size()));
  kestrel::pose_t back{};
  const int decoded = back.decode(buffer.data(), 0, static_cast<int>(buffer.size()));
  Check(decoded == static_cast<int>(buffer.size()) && back.utime == pose.utime &&
            back.child_frame_id == "kestrel" && back.position_m[2] == 0.51,
        "kestrel::pose_t encode/decode round trip (bytes)", decoded);

  std::printf("downstream: %s\n", failures == 0 ? "PASS" : "FAIL");
  return failures == 0 ? 0 : 1;
}
