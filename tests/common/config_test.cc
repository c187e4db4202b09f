// YAML configuration: every error names file, key, value and the accepted range.
#include "common/config.h"

#include <gtest/gtest.h>

namespace kestrel {
namespace {

/// Expects `fn` to throw ConfigError whose message contains every one of `parts`.
template <typename Fn>
void ExpectConfigError(Fn fn, const std::vector<std::string>& parts) {
  try {
    fn();
    FAIL() << "no ConfigError thrown";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    for (const auto& part : parts) {
      EXPECT_NE(what.find(part), std::string::npos) << "'" << part << "' missing from: " << what;
    }
  }
}

struct SensorConfig {
  double sigma_m{0.25};
  double p_rand{0.1};
  int width_px{640};
  std::string encoding{"raw"};
  Eigen::Vector3d offset_m{Eigen::Vector3d::Zero()};
};

void ReadSensor(const ConfigNode& node, SensorConfig* c) {
  node.Read("sigma_m", &c->sigma_m, Range::Positive());
  node.Read("p_rand", &c->p_rand, Range::Open(0.0, 1.0));
  node.Read("width_px", &c->width_px, Range::Closed(1, 4096));
  node.Read("encoding", &c->encoding, {"raw", "zlib"});
  node.Read("offset_m", &c->offset_m);
}

TEST(Config, ReadsValuesAndKeepsDefaultsForAbsentKeys) {
  const ConfigNode root = ConfigNode::FromString(
      "xtion:\n  sigma_m: 0.3\n  encoding: zlib\n  offset_m: [0.1, -0.2, 0.3]\n", "mapper.yaml");
  SensorConfig c;
  ReadSensor(root.Child("xtion"), &c);
  EXPECT_EQ(c.sigma_m, 0.3);
  EXPECT_EQ(c.p_rand, 0.1);
  EXPECT_EQ(c.width_px, 640);
  EXPECT_EQ(c.encoding, "zlib");
  EXPECT_EQ(c.offset_m, Eigen::Vector3d(0.1, -0.2, 0.3));
  root.CheckNoUnknownKeys();
}

TEST(Config, OutOfRangeNamesFileKeyValueAndRange) {
  const ConfigNode root = ConfigNode::FromString("xtion:\n  sigma_m: -0.5\n", "mapper.yaml");
  SensorConfig c;
  ExpectConfigError([&] { ReadSensor(root.Child("xtion"), &c); },
                    {"mapper.yaml", "xtion.sigma_m", "'-0.5'", "(0, inf]", "line 2"});
  EXPECT_EQ(c.sigma_m, 0.25) << "a rejected value must not be stored";
}

TEST(Config, OpenRangeExcludesItsEnds) {
  const ConfigNode root = ConfigNode::FromString("p_rand: 1\n", "s.yaml");
  SensorConfig c;
  ExpectConfigError([&] { ReadSensor(root, &c); }, {"p_rand", "'1'", "(0, 1)"});
}

TEST(Config, WrongTypesAreRejected) {
  SensorConfig c;
  ExpectConfigError([&] { ReadSensor(ConfigNode::FromString("width_px: 3.5\n", "a.yaml"), &c); },
                    {"a.yaml", "width_px", "an integer in [1, 4096]"});
  ExpectConfigError([&] { ReadSensor(ConfigNode::FromString("sigma_m: abc\n", "a.yaml"), &c); },
                    {"sigma_m", "'abc'", "a number"});
  ExpectConfigError([&] { ReadSensor(ConfigNode::FromString("sigma_m: .nan\n", "a.yaml"), &c); },
                    {"sigma_m"});
  ExpectConfigError([&] { ReadSensor(ConfigNode::FromString("encoding: png\n", "a.yaml"), &c); },
                    {"encoding", "'png'", "one of {raw, zlib}"});
  ExpectConfigError([&] { ReadSensor(ConfigNode::FromString("offset_m: [1, 2]\n", "a.yaml"), &c); },
                    {"offset_m", "a list of 3 numbers"});
}

TEST(Config, UnknownKeysAreReportedNotIgnored) {
  const ConfigNode root = ConfigNode::FromString(
      "xtion:\n  sigma_m: 0.3\n  sigmma_m: 0.2\nhokuyo_typo:\n  a: 1\n", "mapper.yaml");
  SensorConfig c;
  ReadSensor(root.Child("xtion"), &c);
  ExpectConfigError([&] { root.CheckNoUnknownKeys(); },
                    {"mapper.yaml", "xtion.sigmma_m", "hokuyo_typo", "unknown keys"});
}

TEST(Config, UnknownKeysInsideListElementsAreReported) {
  const ConfigNode root =
      ConfigNode::FromString("objects:\n  - size_m: 1\n  - size_m: 2\n    colour: red\n", "w.yaml");
  for (const ConfigNode& obj : root.Elements("objects")) {
    double size = 0;
    obj.ReadRequired("size_m", &size, Range::Positive());
  }
  ExpectConfigError([&] { root.CheckNoUnknownKeys(); }, {"objects[1].colour"});
}

// YAML allows a sequence or a mapping as a key; the unknown-key check refuses one with the
// file and line as a ConfigError (it let yaml-cpp's own conversion error escape before, found by
// tests/fuzz/world_fuzz.cc), at the top level and inside list elements.
TEST(Config, NonScalarKeysAreConfigErrors) {
  const ConfigNode top = ConfigNode::FromString("a: 1\n? [x, y]\n: 2\n", "k.yaml");
  double a = 0;
  top.Read("a", &a);
  ExpectConfigError([&] { top.CheckNoUnknownKeys(); }, {"k.yaml", "line 2", "sequence"});
  ExpectConfigError([&] { (void)top.Keys(); }, {"k.yaml", "sequence"});
  const ConfigNode nested =
      ConfigNode::FromString("objects:\n  - size_m: 1\n    ? {p: q}\n    : 3\n", "n.yaml");
  for (const ConfigNode& obj : nested.Elements("objects")) {
    double size = 0;
    obj.ReadRequired("size_m", &size, Range::Positive());
  }
  ExpectConfigError([&] { nested.CheckNoUnknownKeys(); }, {"n.yaml", "line 3", "mapping"});
}

// Elements are read by key: a list element that is a scalar or a list is a ConfigError naming
// it (yaml-cpp's BadSubscript escaped before, found by tests/fuzz/world_fuzz.cc).
TEST(Config, ListElementsMustBeMappings) {
  for (const char* text : {"objects:\n  - 1\n", "objects:\n  - [a, b]\n"}) {
    const ConfigNode root = ConfigNode::FromString(text, "e.yaml");
    ExpectConfigError(
        [&] {
          for (const ConfigNode& obj : root.Elements("objects")) (void)obj.Has("size_m");
        },
        {"e.yaml", "objects[0]", "a mapping"});
  }
}

TEST(Config, MissingRequiredKeyAndChild) {
  const ConfigNode root = ConfigNode::FromString("a: 1\n", "m.yaml");
  double v = 0;
  ExpectConfigError([&] { root.ReadRequired("rate_hz", &v, Range::Positive()); },
                    {"m.yaml", "required key 'rate_hz' is missing"});
  ExpectConfigError([&] { (void)root.Child("xtion"); }, {"required key 'xtion'"});
}

// Validate() of a struct can fail on a key that was absent (a default): still a ConfigError.
TEST(Config, FailOnAnAbsentKeyIsAConfigError) {
  const ConfigNode root = ConfigNode::FromString("a: 1\n", "m.yaml");
  ExpectConfigError([&] { root.Fail("z_max_m", "must exceed z_min_m"); },
                    {"m.yaml", "z_max_m", "must exceed z_min_m"});
}

TEST(Config, BadYamlNamesFileAndLine) {
  ExpectConfigError([] { (void)ConfigNode::FromString("a: 1\nb: [1, 2\n", "bad.yaml"); },
                    {"bad.yaml", "line", "invalid YAML"});
  ExpectConfigError([] { (void)ConfigNode::LoadFile("/nonexistent/kestrel.yaml"); },
                    {"/nonexistent/kestrel.yaml", "cannot open"});
}

TEST(Config, CommandLineOverridesReplaceAndAreChecked) {
  ConfigNode root = ConfigNode::FromString("xtion:\n  sigma_m: 0.3\n", "mapper.yaml");
  root.ApplyOverride("xtion.sigma_m=0.2");
  root.ApplyOverride("xtion.width_px=320");
  SensorConfig c;
  ReadSensor(root.Child("xtion"), &c);
  EXPECT_EQ(c.sigma_m, 0.2);
  EXPECT_EQ(c.width_px, 320);
  root.ApplyOverride("xtion.width_px=0");
  ExpectConfigError([&] { ReadSensor(root.Child("xtion"), &c); }, {"xtion.width_px", "'0'"});
  ExpectConfigError([&] { root.ApplyOverride("novalue"); }, {"novalue", "key.path=value"});
  // A path whose parents do not exist yet creates them.
  root.ApplyOverride("hokuyo.model.sigma_m=0.05");
  double sigma = 0.0;
  root.Child("hokuyo").Child("model").Read("sigma_m", &sigma);
  EXPECT_EQ(sigma, 0.05);
}

TEST(Config, OverridesIndexSequences) {
  ConfigNode root = ConfigNode::FromString(
      "sensors:\n  - {name: xtion, model: {sigma_m: 0.25}}\n  - {name: hokuyo, model: {sigma_m: "
      "0.1}}\n",
      "mapper.yaml");
  root.ApplyOverride("sensors.1.model.sigma_m=0.03");
  const std::vector<ConfigNode> sensors = root.Elements("sensors");
  ASSERT_EQ(sensors.size(), 2u);
  double sigma = 0.0;
  sensors[1].Child("model").Read("sigma_m", &sigma);
  EXPECT_EQ(sigma, 0.03);
  sensors[0].Child("model").Read("sigma_m", &sigma);
  EXPECT_EQ(sigma, 0.25);
  ExpectConfigError([&] { root.ApplyOverride("sensors.2.model.sigma_m=1"); },
                    {"'2'", "not an index", "2 elements"});
  ExpectConfigError([&] { root.ApplyOverride("sensors.x.name=a"); }, {"'x'", "not an index"});
  ExpectConfigError([&] { root.ApplyOverride("sensors.-1.name=a"); }, {"'-1'", "not an index"});
}

}  // namespace
}  // namespace kestrel
