#include "control/mixer.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace kestrel {

Mixer::Mixer(const VehicleConfig& vehicle)
    : geometry_(ComputeRotorGeometry(vehicle)),
      min_rotor_thrust_N_(vehicle.min_rotor_thrust_N),
      max_rotor_thrust_N_(vehicle.max_rotor_thrust_N) {}

MixerOutput Mixer::Mix(double thrust_N, const Eigen::Vector3d& moment_Nm) const {
  MixerOutput out;
  const double lo = min_rotor_thrust_N_;
  const double hi = max_rotor_thrust_N_;
  const Eigen::Matrix4d& B_inv = geometry_.mixer_inverse;
  if (!std::isfinite(thrust_N) || !moment_Nm.allFinite()) {
    out.input_rejected = true;
    out.rotor_thrust_N.setConstant(lo);
  } else {
    // Columns of B^-1: thrust share u (every u_i > 0 for the symmetric layouts), roll/pitch and
    // yaw differentials.
    const Eigen::Vector4d u = B_inv.col(0);
    Eigen::Vector4d d_rp = B_inv.col(1) * moment_Nm.x() + B_inv.col(2) * moment_Nm.y();
    const Eigen::Vector4d d_yaw = B_inv.col(3) * moment_Nm.z();

    // 1. Roll/pitch: the smallest collective that lifts every rotor to lo is c_lo; the largest
    // keeping every rotor under hi is c_hi. Feasible iff c_lo <= c_hi; otherwise scale d_rp.
    auto collective_bounds = [&](const Eigen::Vector4d& d, double* c_lo, double* c_hi) {
      *c_lo = -std::numeric_limits<double>::infinity();
      *c_hi = std::numeric_limits<double>::infinity();
      for (int i = 0; i < 4; ++i) {
        *c_lo = std::max(*c_lo, (lo - d[i]) / u[i]);
        *c_hi = std::min(*c_hi, (hi - d[i]) / u[i]);
      }
    };
    double c_lo = 0.0;
    double c_hi = 0.0;
    collective_bounds(d_rp, &c_lo, &c_hi);
    if (c_lo > c_hi) {
      // The rotor spread of s * d_rp is s * spread; it fits when s * spread <= hi - lo (with
      // equal shares u_i). Bisection keeps this exact for any u.
      double s_ok = 0.0;
      double s_bad = 1.0;
      for (int iteration = 0; iteration < 60; ++iteration) {
        const double s = 0.5 * (s_ok + s_bad);
        double a = 0.0;
        double b = 0.0;
        collective_bounds(s * d_rp, &a, &b);
        (a <= b ? s_ok : s_bad) = s;
      }
      d_rp *= s_ok;
      collective_bounds(d_rp, &c_lo, &c_hi);
      if (c_lo > c_hi) c_lo = c_hi;  // rounding: a single feasible collective
      out.roll_pitch_saturated = true;
    }

    // 2. Collective clamped to [f_min(M_xy), f_max(M_xy)].
    double collective = thrust_N;
    if (collective < c_lo || collective > c_hi) {
      collective = std::clamp(collective, c_lo, c_hi);
      out.thrust_saturated = true;
    }
    const Eigen::Vector4d base = collective * u + d_rp;

    // 3. Yaw: the largest s in [0, 1] with lo <= base + s d_yaw <= hi.
    double s_yaw = 1.0;
    for (int i = 0; i < 4; ++i) {
      if (d_yaw[i] > 0.0) {
        s_yaw = std::min(s_yaw, std::max(0.0, (hi - base[i]) / d_yaw[i]));
      } else if (d_yaw[i] < 0.0) {
        s_yaw = std::min(s_yaw, std::max(0.0, (lo - base[i]) / d_yaw[i]));
      }
    }
    if (s_yaw < 1.0) out.yaw_saturated = true;
    out.rotor_thrust_N = base + s_yaw * d_yaw;
  }
  // Rounding can leave 1e-15 outside the limits: the last word is a clamp.
  out.rotor_thrust_N = out.rotor_thrust_N.cwiseMax(lo).cwiseMin(hi);
  const Eigen::Vector4d wrench = geometry_.mixer * out.rotor_thrust_N;
  out.thrust_N = wrench[0];
  out.moment_Nm = wrench.tail<3>();
  return out;
}

}  // namespace kestrel
