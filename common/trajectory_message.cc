#include "common/trajectory_message.h"

#include "common/clock.h"

namespace kestrel {

trajectory_t ToMessage(const PiecewisePolynomialTrajectory& trajectory, int64_t utime, int64_t seq,
                       int64_t epoch) {
  const FlatTrajectory flat = trajectory.ToFlat();
  trajectory_t msg{};
  msg.utime = utime;
  msg.seq = seq;
  msg.epoch = epoch;
  msg.start_utime = SecondsToUtime(flat.start_time_s);
  msg.num_segments = static_cast<int32_t>(flat.durations_s.size());
  msg.num_coeffs = flat.num_coefficients;
  msg.durations_s = flat.durations_s;
  const size_t n = static_cast<size_t>(flat.num_coefficients);
  auto rows = [&](const std::vector<double>& axis) {
    std::vector<std::vector<double>> out(flat.durations_s.size());
    for (size_t s = 0; s < out.size(); ++s)
      out[s].assign(axis.begin() + static_cast<std::ptrdiff_t>(s * n),
                    axis.begin() + static_cast<std::ptrdiff_t>((s + 1) * n));
    return out;
  };
  msg.coeffs_x = rows(flat.x);
  msg.coeffs_y = rows(flat.y);
  msg.coeffs_z = rows(flat.z);
  msg.coeffs_yaw = rows(flat.yaw);
  return msg;
}

std::optional<PiecewisePolynomialTrajectory> FromMessage(const trajectory_t& msg,
                                                         std::string* error) {
  const size_t segments = static_cast<size_t>(std::max(0, msg.num_segments));
  auto flatten = [&](const std::vector<std::vector<double>>& rows, std::vector<double>* out) {
    if (rows.size() != segments) return false;
    for (const auto& row : rows) {
      if (row.size() != static_cast<size_t>(std::max(0, msg.num_coeffs))) return false;
      out->insert(out->end(), row.begin(), row.end());
    }
    return true;
  };
  std::vector<double> x, y, z, yaw;
  if (msg.durations_s.size() != segments || !flatten(msg.coeffs_x, &x) ||
      !flatten(msg.coeffs_y, &y) || !flatten(msg.coeffs_z, &z) || !flatten(msg.coeffs_yaw, &yaw)) {
    if (error != nullptr) *error = "trajectory_t rows do not match num_segments x num_coeffs";
    return std::nullopt;
  }
  return PiecewisePolynomialTrajectory::CreateFromFlat(
      UtimeToSeconds(msg.start_utime), msg.durations_s, msg.num_coeffs, x, y, z, yaw, error);
}

}  // namespace kestrel
