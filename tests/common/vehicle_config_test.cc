#include "common/vehicle_config.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <regex>
#include <string>

#include "common/config.h"

namespace kestrel {
namespace {

// Expected sign of each rotor's contribution, derived by hand from the geometry (X layout):
// rotor 1 front-right (+x, -y), 2 front-left (+x, +y), 3 back-left (-x, +y), 4 back-right
// (-x, -y). Roll M_x = sum r_y T: positive from the left rotors 2, 3. Pitch M_y = sum -r_x T
// (nose down positive): positive from the back rotors 3, 4. Yaw: a clockwise rotor (1, 3) pushes
// the body counter-clockwise, +z.
TEST(VehicleConfig, XLayoutMixerSignsFollowTheGeometry) {
  VehicleConfig config;
  config.layout = "x";
  const RotorGeometry g = ComputeRotorGeometry(config);
  const double a = config.arm_length_m / std::sqrt(2.0);
  const double k = config.drag_torque_coefficient_m;
  Eigen::Matrix4d expected;
  expected << 1, 1, 1, 1,  //
      -a, a, a, -a,        // roll: left rotors (2, 3) positive
      -a, -a, a, a,        // pitch: back rotors (3, 4) positive
      k, -k, k, -k;        // yaw: clockwise rotors (1, 3) positive
  EXPECT_LT((g.mixer - expected).cwiseAbs().maxCoeff(), 1e-15) << g.mixer;
  EXPECT_LT((g.position_B_m.col(0) - Eigen::Vector3d(a, -a, 0)).norm(), 1e-15);
  EXPECT_EQ(g.spin[0], -1.0);  // rotor 1 clockwise seen from above
  EXPECT_EQ(g.spin[1], 1.0);
}

// Plus layout: rotor 1 front (+x), 2 left (+y), 3 back (-x), 4 right (-y).
TEST(VehicleConfig, PlusLayoutMixerSignsFollowTheGeometry) {
  VehicleConfig config;
  config.layout = "plus";
  const RotorGeometry g = ComputeRotorGeometry(config);
  const double d = config.arm_length_m;
  const double k = config.drag_torque_coefficient_m;
  Eigen::Matrix4d expected;
  expected << 1, 1, 1, 1,  //
      0, d, 0, -d,         // roll: the left rotor 2 up
      -d, 0, d, 0,         // pitch: the back rotor 3 (nose down)
      k, -k, k, -k;        // yaw
  EXPECT_LT((g.mixer - expected).cwiseAbs().maxCoeff(), 1e-15) << g.mixer;
}

// The mixer is r x F plus drag torque, computed here explicitly rotor by rotor with cross
// products, and the inverse is an inverse.
TEST(VehicleConfig, MixerIsTheSumOfRotorForcesAndTorques) {
  for (const char* layout : {"x", "plus"}) {
    VehicleConfig config;
    config.layout = layout;
    const RotorGeometry g = ComputeRotorGeometry(config);
    const Eigen::Vector4d T(3.0, 7.0, 11.0, 13.0);
    Eigen::Vector3d moment = Eigen::Vector3d::Zero();
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector3d force(0.0, 0.0, T[i]);
      const Eigen::Vector3d r = g.position_B_m.col(i);
      moment += r.cross(force);
      // Reaction torque opposes the rotor's spin: -spin * k_m * T about z_B.
      moment.z() += -g.spin[static_cast<size_t>(i)] * config.drag_torque_coefficient_m * T[i];
    }
    const Eigen::Vector4d wrench = g.mixer * T;
    EXPECT_NEAR(wrench[0], T.sum(), 1e-12);
    EXPECT_LT((wrench.tail<3>() - moment).norm(), 1e-12) << layout;
    EXPECT_LT((g.mixer_inverse * g.mixer - Eigen::Matrix4d::Identity()).norm(), 1e-12);
    EXPECT_LT((g.mixer * g.mixer_inverse - Eigen::Matrix4d::Identity()).norm(), 1e-12);
  }
}

// A pure positive roll / pitch / yaw moment, inverted, speeds up exactly the rotors the geometry
// says (X layout: roll 2, 3; pitch 3, 4; yaw 1, 3) and slows the others, with zero net thrust.
TEST(VehicleConfig, PureMomentsGiveExpectedRotorSigns) {
  VehicleConfig config;
  const RotorGeometry g = ComputeRotorGeometry(config);
  const Eigen::Vector4d roll = g.mixer_inverse * Eigen::Vector4d(0, 1, 0, 0);
  const Eigen::Vector4d pitch = g.mixer_inverse * Eigen::Vector4d(0, 0, 1, 0);
  const Eigen::Vector4d yaw = g.mixer_inverse * Eigen::Vector4d(0, 0, 0, 1);
  const Eigen::Vector4d expected_roll(-1, 1, 1, -1);
  const Eigen::Vector4d expected_pitch(-1, -1, 1, 1);
  const Eigen::Vector4d expected_yaw(1, -1, 1, -1);
  for (int i = 0; i < 4; ++i) {
    EXPECT_GT(roll[i] * expected_roll[i], 0.0) << i;
    EXPECT_GT(pitch[i] * expected_pitch[i], 0.0) << i;
    EXPECT_GT(yaw[i] * expected_yaw[i], 0.0) << i;
  }
  EXPECT_NEAR(roll.sum(), 0.0, 1e-12);
  EXPECT_NEAR(pitch.sum(), 0.0, 1e-12);
  EXPECT_NEAR(yaw.sum(), 0.0, 1e-12);
  // Pure thrust: equal shares.
  const Eigen::Vector4d hover = g.mixer_inverse * Eigen::Vector4d(40, 0, 0, 0);
  EXPECT_LT((hover - Eigen::Vector4d::Constant(10.0)).norm(), 1e-12);
}

// The default extrinsic of the depth camera is the optical convention: z_S forward, x_S right,
// y_S down.
TEST(VehicleConfig, DepthCameraUsesOpticalConvention) {
  const VehicleConfig config;
  const Eigen::Matrix3d R_BS = config.X_BS_xtion.rotation();
  EXPECT_LT((R_BS * Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitX()).norm(), 1e-12);
  EXPECT_LT((R_BS * Eigen::Vector3d::UnitX() + Eigen::Vector3d::UnitY()).norm(), 1e-12);
  EXPECT_LT((R_BS * Eigen::Vector3d::UnitY() + Eigen::Vector3d::UnitZ()).norm(), 1e-12);
}

TEST(VehicleConfig, ValidateNamesFieldValueAndRange) {
  VehicleConfig config;
  config.Validate();
  config.mass_kg = -1.0;
  EXPECT_THROW(
      {
        try {
          config.Validate();
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find("vehicle.mass_kg = -1, accepted (0, 100]"),
                    std::string::npos)
              << e.what();
          throw;
        }
      },
      std::invalid_argument);
  config = VehicleConfig{};
  config.layout = "hex";
  EXPECT_THROW(config.Validate(), std::invalid_argument);
  config = VehicleConfig{};
  config.max_rotor_thrust_N = 5.0;  // 4 x 5 N cannot lift 4.34 kg
  EXPECT_THROW(config.Validate(), std::invalid_argument);
  config = VehicleConfig{};
  config.X_BS_xtion.q.coeffs() *= 2.0;
  EXPECT_THROW(config.Validate(), std::invalid_argument);
}

std::string ExpectConfigError(const std::string& yaml) {
  try {
    (void)LoadVehicleConfig(ConfigNode::FromString(yaml, "test_vehicle.yaml"));
  } catch (const ConfigError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no ConfigError for:\n" << yaml;
  return "";
}

// Errors from YAML name the file, the key and the accepted range.
TEST(VehicleConfig, YamlErrorsNameFileKeyAndRange) {
  std::string message = ExpectConfigError("mass_kg: -3\n");
  EXPECT_NE(message.find("test_vehicle.yaml"), std::string::npos) << message;
  EXPECT_NE(message.find("mass_kg"), std::string::npos) << message;
  EXPECT_NE(message.find("(0, 100)"), std::string::npos) << message;

  message = ExpectConfigError("layout: hex\n");
  EXPECT_NE(message.find("layout"), std::string::npos) << message;
  EXPECT_NE(message.find("plus"), std::string::npos) << message;

  message = ExpectConfigError("mass_kg: 4.0\nmass_kgg: 4.0\n");
  EXPECT_NE(message.find("mass_kgg"), std::string::npos) << message;

  message = ExpectConfigError("sensors:\n  xtion:\n    orientation_wxyz: [1, 1, 0, 0]\n");
  EXPECT_NE(message.find("sensors.xtion.orientation_wxyz"), std::string::npos) << message;

  // A cross-field check (J_a + J_b >= J_c) names the file and the field.
  message = ExpectConfigError("inertia_kgm2: [0.01, 0.01, 0.5]\n");
  EXPECT_NE(message.find("test_vehicle.yaml"), std::string::npos) << message;
  EXPECT_NE(message.find("inertia_kgm2"), std::string::npos) << message;

  message = ExpectConfigError("min_rotor_thrust_N: 30\nmax_rotor_thrust_N: 20\n");
  EXPECT_NE(message.find("max_rotor_thrust_N"), std::string::npos) << message;
  EXPECT_NE(message.find("test_vehicle.yaml"), std::string::npos) << message;
}

TEST(VehicleConfig, LoadsAllKeysFromYaml) {
  const VehicleConfig config = LoadVehicleConfig(ConfigNode::FromString(
      "mass_kg: 1.5\ninertia_kgm2: [0.01, 0.02, 0.025]\narm_length_m: 0.2\nlayout: plus\n"
      "thrust_coefficient_N_per_radps2: 2e-6\ndrag_torque_coefficient_m: 0.02\n"
      "motor_time_constant_s: 0.03\nmax_rotor_thrust_N: 8\nmin_rotor_thrust_N: 0.5\n"
      "linear_drag_Ns_per_m: [0.3, 0.4, 0.5]\ndiameter_m: 0.6\n"
      "sensors:\n  hokuyo:\n    position_m: [0.1, 0.2, 0.3]\n"
      "    orientation_wxyz: [0.0, 0.0, 0.0, 1.0]\n",
      "inline.yaml"));
  EXPECT_EQ(config.mass_kg, 1.5);
  EXPECT_EQ(config.inertia_kgm2, Eigen::Vector3d(0.01, 0.02, 0.025));
  EXPECT_EQ(config.layout, "plus");
  EXPECT_EQ(config.min_rotor_thrust_N, 0.5);
  EXPECT_EQ(config.linear_drag_Ns_per_m, Eigen::Vector3d(0.3, 0.4, 0.5));
  EXPECT_EQ(config.X_BS_hokuyo.p, Eigen::Vector3d(0.1, 0.2, 0.3));
  EXPECT_NEAR(config.X_BS_hokuyo.q.z(), 1.0, 1e-15);
  EXPECT_EQ(config.X_BS_xtion.q.w(), 0.5);  // untouched default
}

// The repository root (KESTREL_SOURCE_ROOT, set by tests/common/CMakeLists.txt).
std::string SourceRoot() { return KESTREL_SOURCE_ROOT; }

// The shipped files load and agree with the paper's values.
TEST(VehicleConfig, ShippedPaperFileHasPaperValues) {
  const std::string path = SourceRoot() + "config/vehicle/paper.yaml";
  const VehicleConfig paper = LoadVehicleConfigFile(path);
  EXPECT_EQ(paper.mass_kg, 4.34);
  EXPECT_EQ(paper.inertia_kgm2, Eigen::Vector3d(0.0820, 0.0845, 0.1377));
  EXPECT_EQ(paper.arm_length_m, 0.315);
  EXPECT_EQ(paper.motor_time_constant_s, 0.02);
  const VehicleConfig small = LoadVehicleConfigFile(SourceRoot() + "config/vehicle/small.yaml");
  EXPECT_LT(small.mass_kg, paper.mass_kg);
}

}  // namespace
}  // namespace kestrel
