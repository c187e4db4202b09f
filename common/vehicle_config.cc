#include "common/vehicle_config.h"

#include <cmath>
#include <stdexcept>

#include <Eigen/LU>

#include "common/check.h"
#include "common/config.h"

namespace kestrel {

namespace {

constexpr double kPi = 3.14159265358979323846;

bool IsUnitQuaternion(const Eigen::Quaterniond& q) {
  return q.coeffs().allFinite() && std::abs(q.norm() - 1.0) < 1e-6;
}

void ValidateExtrinsic(const Pose3& X_BS, const char* name) {
  KESTREL_THROW_UNLESS(X_BS.p.allFinite() && X_BS.p.norm() < 10.0,
                       "vehicle." << name << ".position_m = [" << X_BS.p.transpose()
                                  << "], accepted finite, |p| < 10 m");
  KESTREL_THROW_UNLESS(IsUnitQuaternion(X_BS.q),
                       "vehicle." << name << ".orientation_wxyz = [" << X_BS.q.w() << " "
                                  << X_BS.q.vec().transpose() << "], accepted a unit quaternion");
}

void ReadExtrinsic(const ConfigNode& sensors, const char* name, Pose3* X_BS) {
  if (!sensors.Has(name)) return;
  const ConfigNode sensor = sensors.Child(name);
  Eigen::Vector3d p = X_BS->p;
  sensor.Read("position_m", &p, Range::Closed(-10.0, 10.0));
  Eigen::Vector4d wxyz(X_BS->q.w(), X_BS->q.x(), X_BS->q.y(), X_BS->q.z());
  sensor.Read("orientation_wxyz", &wxyz, Range::Closed(-1.0, 1.0));
  if (std::abs(wxyz.norm() - 1.0) > 1e-3) {
    sensor.Fail("orientation_wxyz", "norm " + std::to_string(wxyz.norm()) +
                                        " is not 1 (accepted |q| within 1e-3 of 1)");
  }
  X_BS->p = p;
  X_BS->q = Eigen::Quaterniond(wxyz[0], wxyz[1], wxyz[2], wxyz[3]).normalized();
}

}  // namespace

void VehicleConfig::Validate() const {
  KESTREL_THROW_UNLESS(std::isfinite(mass_kg) && mass_kg > 0.0 && mass_kg <= 100.0,
                       "vehicle.mass_kg = " << mass_kg << ", accepted (0, 100]");
  KESTREL_THROW_UNLESS(
      inertia_kgm2.allFinite() && (inertia_kgm2.array() > 0.0).all() &&
          (inertia_kgm2.array() <= 100.0).all(),
      "vehicle.inertia_kgm2 = [" << inertia_kgm2.transpose() << "], accepted each in (0, 100]");
  // A physical inertia satisfies the triangle inequalities J_a + J_b >= J_c.
  const Eigen::Vector3d& J = inertia_kgm2;
  KESTREL_THROW_UNLESS(
      J[0] + J[1] >= J[2] && J[1] + J[2] >= J[0] && J[0] + J[2] >= J[1],
      "vehicle.inertia_kgm2 = [" << J.transpose() << "] violates J_a + J_b >= J_c");
  KESTREL_THROW_UNLESS(std::isfinite(arm_length_m) && arm_length_m > 0.0 && arm_length_m <= 5.0,
                       "vehicle.arm_length_m = " << arm_length_m << ", accepted (0, 5]");
  KESTREL_THROW_UNLESS(layout == "x" || layout == "plus",
                       "vehicle.layout = \"" << layout << "\", accepted \"x\" or \"plus\"");
  KESTREL_THROW_UNLESS(
      std::isfinite(thrust_coefficient_N_per_radps2) && thrust_coefficient_N_per_radps2 > 0.0,
      "vehicle.thrust_coefficient_N_per_radps2 = " << thrust_coefficient_N_per_radps2
                                                   << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(drag_torque_coefficient_m) && drag_torque_coefficient_m > 0.0 &&
          drag_torque_coefficient_m <= 1.0,
      "vehicle.drag_torque_coefficient_m = " << drag_torque_coefficient_m << ", accepted (0, 1]");
  KESTREL_THROW_UNLESS(
      std::isfinite(motor_time_constant_s) && motor_time_constant_s >= 0.0 &&
          motor_time_constant_s <= 1.0,
      "vehicle.motor_time_constant_s = " << motor_time_constant_s << ", accepted [0, 1]");
  KESTREL_THROW_UNLESS(
      std::isfinite(min_rotor_thrust_N) && min_rotor_thrust_N >= 0.0,
      "vehicle.min_rotor_thrust_N = " << min_rotor_thrust_N << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(max_rotor_thrust_N) && max_rotor_thrust_N > min_rotor_thrust_N,
                       "vehicle.max_rotor_thrust_N = " << max_rotor_thrust_N
                                                       << ", accepted (min_rotor_thrust_N = "
                                                       << min_rotor_thrust_N << ", inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(esc.full_command_thrust_N) && esc.full_command_thrust_N >= max_rotor_thrust_N,
      "vehicle.esc.full_command_thrust_N = " << esc.full_command_thrust_N
                                             << " must reach max_rotor_thrust_N = "
                                             << max_rotor_thrust_N);
  KESTREL_THROW_UNLESS(esc.idle_command >= 0.0 && esc.idle_command <= 0.3,
                       "vehicle.esc.idle_command = " << esc.idle_command << " is not in [0, 0.3]");
  KESTREL_THROW_UNLESS(4.0 * max_rotor_thrust_N > mass_kg * kGravity_mps2,
                       "vehicle.max_rotor_thrust_N = "
                           << max_rotor_thrust_N << " cannot lift mass_kg = " << mass_kg
                           << ": accepted 4 T_max > m g = " << mass_kg * kGravity_mps2 << " N");
  KESTREL_THROW_UNLESS(4.0 * min_rotor_thrust_N < mass_kg * kGravity_mps2,
                       "vehicle.min_rotor_thrust_N = " << min_rotor_thrust_N
                                                       << ": accepted 4 T_min < m g = "
                                                       << mass_kg * kGravity_mps2 << " N");
  KESTREL_THROW_UNLESS(
      linear_drag_Ns_per_m.allFinite() && (linear_drag_Ns_per_m.array() >= 0.0).all(),
      "vehicle.linear_drag_Ns_per_m = [" << linear_drag_Ns_per_m.transpose()
                                         << "], accepted each in [0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(diameter_m) && diameter_m >= 2.0 * arm_length_m && diameter_m <= 10.0,
      "vehicle.diameter_m = " << diameter_m << ", accepted [2 arm_length_m = " << 2.0 * arm_length_m
                              << ", 10]");
  ValidateExtrinsic(X_BS_xtion, "sensors.xtion");
  ValidateExtrinsic(X_BS_hokuyo, "sensors.hokuyo");
}

RotorGeometry ComputeRotorGeometry(const VehicleConfig& config) {
  config.Validate();
  RotorGeometry geometry;
  // Rotor 1 at azimuth -45 deg (x: front-right) or 0 deg (plus: front); then +90 deg each,
  // counter-clockwise seen from above (azimuth measured from x_B towards y_B = left).
  const double first_azimuth_rad = config.layout == "x" ? -kPi / 4.0 : 0.0;
  for (int i = 0; i < 4; ++i) {
    const double azimuth_rad = first_azimuth_rad + static_cast<double>(i) * kPi / 2.0;
    double c = std::cos(azimuth_rad);
    double s = std::sin(azimuth_rad);
    // Exact zeros on the axes (plus layout) keep the mixer free of 1e-17 cross terms.
    if (std::abs(c) < 1e-12) c = 0.0;
    if (std::abs(s) < 1e-12) s = 0.0;
    geometry.position_B_m.col(i) = config.arm_length_m * Eigen::Vector3d(c, s, 0.0);
    geometry.spin[static_cast<size_t>(i)] = (i % 2 == 0) ? -1.0 : 1.0;  // rotor 1 clockwise
  }
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d r = geometry.position_B_m.col(i);
    // Moment of thrust T z_B at r: r x (0, 0, T) = (r_y T, -r_x T, 0); drag torque -s k_m T z_B.
    geometry.mixer(0, i) = 1.0;
    geometry.mixer(1, i) = r.y();
    geometry.mixer(2, i) = -r.x();
    geometry.mixer(3, i) =
        -geometry.spin[static_cast<size_t>(i)] * config.drag_torque_coefficient_m;
  }
  geometry.mixer_inverse = geometry.mixer.inverse();
  KESTREL_DEMAND(geometry.mixer_inverse.allFinite());
  return geometry;
}

VehicleConfig LoadVehicleConfig(const ConfigNode& node) {
  VehicleConfig config;
  node.Read("mass_kg", &config.mass_kg, Range::Open(0.0, 100.0));
  node.Read("inertia_kgm2", &config.inertia_kgm2, Range::Open(0.0, 100.0));
  node.Read("arm_length_m", &config.arm_length_m, Range::Open(0.0, 5.0));
  node.Read("layout", &config.layout, std::vector<std::string>{"x", "plus"});
  node.Read("thrust_coefficient_N_per_radps2", &config.thrust_coefficient_N_per_radps2,
            Range::Positive());
  node.Read("drag_torque_coefficient_m", &config.drag_torque_coefficient_m,
            Range{0.0, 1.0, false, true});
  node.Read("motor_time_constant_s", &config.motor_time_constant_s, Range::Closed(0.0, 1.0));
  node.Read("max_rotor_thrust_N", &config.max_rotor_thrust_N, Range::Positive());
  node.Read("min_rotor_thrust_N", &config.min_rotor_thrust_N, Range::NonNegative());
  node.Read("linear_drag_Ns_per_m", &config.linear_drag_Ns_per_m, Range::NonNegative());
  node.Read("diameter_m", &config.diameter_m, Range{0.0, 10.0, false, true});
  if (node.Has("esc")) {
    const ConfigNode esc = node.Child("esc");
    esc.Read("full_command_thrust_N", &config.esc.full_command_thrust_N, Range::Positive());
    esc.Read("idle_command", &config.esc.idle_command, Range::Closed(0.0, 0.3));
  }
  if (node.Has("sensors")) {
    const ConfigNode sensors = node.Child("sensors");
    ReadExtrinsic(sensors, "xtion", &config.X_BS_xtion);
    ReadExtrinsic(sensors, "hokuyo", &config.X_BS_hokuyo);
  }
  node.CheckNoUnknownKeys();
  // Cross-field checks, reported with the file and key.
  if (config.max_rotor_thrust_N <= config.min_rotor_thrust_N) {
    node.Fail("max_rotor_thrust_N",
              "= " + std::to_string(config.max_rotor_thrust_N) +
                  " must exceed min_rotor_thrust_N = " + std::to_string(config.min_rotor_thrust_N));
  }
  try {
    config.Validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(node.file() + ": " + e.what());
  }
  return config;
}

VehicleConfig LoadVehicleConfigFile(const std::string& path) {
  return LoadVehicleConfig(ConfigNode::LoadFile(path));
}

VehicleConfig LoadVehicleConfigFile(const std::string& path, const ConfigNode& including) {
  return LoadVehicleConfig(including.Include(path));
}

}  // namespace kestrel
