#include "exploration/separation.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace kestrel {

std::optional<Eigen::Vector3d> PeerPositionAt(const PeerMotion& peer, double t_s) {
  const bool seen_after_end = peer.seen && peer.trajectory.has_value() &&
                              peer.position_time_s > peer.trajectory->end_time_s();
  if (peer.trajectory.has_value() && !seen_after_end &&
      (t_s >= peer.trajectory->start_time_s() || !peer.seen)) {
    return peer.trajectory->Evaluate(t_s).position_m;
  }
  if (peer.seen) return peer.position_m;
  return std::nullopt;
}

double SeparationAt(const Eigen::Vector3d& own_m, const PeerMotion& peer, double t_s,
                    double vertical_m) {
  const std::optional<Eigen::Vector3d> q = PeerPositionAt(peer, t_s);
  if (!q || std::abs(own_m.z() - q->z()) >= vertical_m) {
    return std::numeric_limits<double>::infinity();
  }
  return (own_m - *q).head<2>().norm();
}

Separation ClosestApproach(const PiecewisePolynomialTrajectory& own, double from_s,
                           const std::vector<PeerMotion>& peers, double vertical_m, double dt_s,
                           double hold_s) {
  Separation closest;
  double end_s = std::max(from_s, own.end_time_s());
  for (const PeerMotion& p : peers) {
    if (p.trajectory.has_value()) end_s = std::max(end_s, p.trajectory->end_time_s());
  }
  end_s += hold_s;
  const int steps = static_cast<int>(std::ceil((end_s - from_s) / dt_s));
  for (int i = 0; i <= steps; ++i) {
    const double t = std::min(from_s + i * dt_s, end_s);
    const Eigen::Vector3d own_p = own.Evaluate(t).position_m;
    for (const PeerMotion& p : peers) {
      const double d = SeparationAt(own_p, p, t, vertical_m);
      if (d < closest.distance_m) closest = Separation{d, t, p.name};
    }
  }
  return closest;
}

std::vector<Eigen::Vector3d> PeerGoals(const std::vector<PeerMotion>& peers) {
  std::vector<Eigen::Vector3d> goals;
  for (const PeerMotion& p : peers) {
    if (!p.trajectory.has_value()) continue;
    const FlatOutput end = p.trajectory->Evaluate(p.trajectory->end_time_s());
    goals.emplace_back(end.position_m.x(), end.position_m.y(), end.yaw_rad);
  }
  return goals;
}

}  // namespace kestrel
