// YAML configuration: every error names file, key, value and the accepted range.
#include "common/config.h"

#include <fstream>

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

// A value that came from --set is named by its override, not by a line of the file: the
// override's YAML is parsed alone, so its "line 1" would point at the file's first line.
TEST(Config, ABadOverrideIsNamedAsTheOverrideNotAFileLine) {
  ConfigNode root = ConfigNode::FromString("a: 1\nb: 2\nxtion:\n  sigma_m: 0.3\n", "mapper.yaml");
  root.ApplyOverride("xtion.width_px=0");
  SensorConfig c;
  try {
    ReadSensor(root.Child("xtion"), &c);
    FAIL() << "no ConfigError thrown";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("xtion.width_px' (from --set xtion.width_px=0) has value '0'"),
              std::string::npos)
        << what;
    EXPECT_EQ(what.find("line"), std::string::npos) << what;
  }
  // A section set by an override names that override for the keys below it.
  root.ApplyOverride("xtion={sigma_m: -1}");
  ExpectConfigError([&] { ReadSensor(root.Child("xtion"), &c); },
                    {"xtion.sigma_m' (from --set xtion={sigma_m: -1})"});
  // The file's own bad value still names its line.
  ConfigNode file = ConfigNode::FromString("a: 1\nxtion:\n  sigma_m: -0.3\n", "mapper.yaml");
  ExpectConfigError([&] { ReadSensor(file.Child("xtion"), &c); }, {"xtion.sigma_m' (line 3)"});
  // An unknown key from an override, and a cross-field check (Fail) on an overridden key.
  ConfigNode typo = ConfigNode::FromString("a: 1\n", "mapper.yaml");
  typo.ApplyOverride("sigma_mm=2");
  double a = 0;
  typo.Read("a", &a);
  ExpectConfigError([&] { typo.CheckNoUnknownKeys(); }, {"sigma_mm (from --set sigma_mm=2)"});
  typo.ApplyOverride("a=5");
  ExpectConfigError([&] { typo.Fail("a", "must be below b"); },
                    {"'a' (from --set a=5) = '5': must be below b"});
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

// --- The effective configuration (EffectiveValues): what a process publishes as params_t.

const ConfigValue* FindValue(const std::vector<ConfigValue>& values, const std::string& key) {
  for (const ConfigValue& v : values) {
    if (v.key == key) return &v;
  }
  return nullptr;
}

TEST(ConfigEffectiveValues, RecordsEveryReadWithItsValueAndSource) {
  ConfigNode root = ConfigNode::FromString(
      "a: 0.1\nsensor:\n  sigma_m: 0.3\n  name: xtion\nlist:\n  - {w: 1}\n  - {w: 2}\n",
      "test.yaml");
  root.ApplyOverride("sensor.name=hokuyo");
  root.ApplyOverride("list.1.w=5");
  double a = 0.0, b = 2.5, sigma = 0.0;
  int rate_hz = 30;
  std::string name;
  root.Read("a", &a);
  root.Read("b", &b);  // absent: the default stays and is recorded as such
  const ConfigNode sensor = root.Child("sensor");
  sensor.Read("sigma_m", &sigma);
  sensor.Read("name", &name);
  sensor.Read("rate_hz", &rate_hz);
  std::vector<int> w;
  for (const ConfigNode& e : root.Elements("list")) {
    int v = 0;
    e.Read("w", &v);
    w.push_back(v);
  }
  const std::vector<ConfigValue> values = root.EffectiveValues();
  struct Expected {
    const char* key;
    const char* value;
    ConfigSource source;
  };
  const Expected expected[] = {{"a", "0.1", ConfigSource::kFile},
                               {"b", "2.5", ConfigSource::kDefault},
                               {"sensor.sigma_m", "0.3", ConfigSource::kFile},
                               {"sensor.name", "hokuyo", ConfigSource::kOverride},
                               {"sensor.rate_hz", "30", ConfigSource::kDefault},
                               {"list[0].w", "1", ConfigSource::kFile},
                               {"list[1].w", "5", ConfigSource::kOverride}};
  ASSERT_EQ(values.size(), std::size(expected));
  for (size_t i = 0; i < values.size(); ++i) {  // in the order read
    EXPECT_EQ(values[i].key, expected[i].key);
    EXPECT_EQ(values[i].value, expected[i].value) << values[i].key;
    EXPECT_EQ(values[i].source, expected[i].source) << values[i].key;
    EXPECT_EQ(values[i].file, "test.yaml");
  }
  EXPECT_EQ(w, (std::vector<int>{1, 5}));
}

TEST(ConfigEffectiveValues, AnOverriddenSectionMarksTheKeysBelowIt) {
  ConfigNode root = ConfigNode::FromString("sensor:\n  sigma_m: 0.3\n", "test.yaml");
  root.ApplyOverride("sensor={sigma_m: 0.2, p_rand: 0.05}");
  double sigma = 0.0, p_rand = 0.0, p_hit = 0.7;
  const ConfigNode sensor = root.Child("sensor");
  sensor.Read("sigma_m", &sigma);
  sensor.Read("p_rand", &p_rand);
  sensor.Read("p_hit", &p_hit);
  const std::vector<ConfigValue> values = root.EffectiveValues();
  ASSERT_NE(FindValue(values, "sensor.sigma_m"), nullptr);
  EXPECT_EQ(FindValue(values, "sensor.sigma_m")->source, ConfigSource::kOverride);
  EXPECT_EQ(FindValue(values, "sensor.sigma_m")->value, "0.2");
  EXPECT_EQ(FindValue(values, "sensor.p_rand")->source, ConfigSource::kOverride);
  EXPECT_EQ(FindValue(values, "sensor.p_hit")->source, ConfigSource::kDefault);
}

TEST(ConfigEffectiveValues, ValuesReadBackExactly) {
  ConfigNode root = ConfigNode::FromString(
      "third: 0.333333333333333314829616256247\ntiny: 1e-5\nbig: 3e8\nflag: yes\n"
      "id: 9007199254740993\noffset: [0, -0.045, 1.5]\nq: [1, 0, 0, 0]\n",
      "test.yaml");
  double third = 0.0, tiny = 0.0, big = 0.0, unset = 0.1 + 0.2;
  float f = 0.1F;
  bool flag = false;
  int64_t id = 0;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  Eigen::Vector4d q = Eigen::Vector4d::Zero();
  root.Read("third", &third);
  root.Read("tiny", &tiny);
  root.Read("big", &big);
  root.Read("unset", &unset);
  root.Read("f", &f);
  root.Read("flag", &flag);
  root.Read("id", &id);
  root.Read("offset", &offset);
  root.Read("q", &q);
  const std::vector<ConfigValue> values = root.EffectiveValues();
  // Each number's text parses back to the very double the process holds.
  for (const auto& [key, held] : std::vector<std::pair<std::string, double>>{
           {"third", third}, {"tiny", tiny}, {"big", big}, {"unset", unset}}) {
    ASSERT_NE(FindValue(values, key), nullptr) << key;
    EXPECT_EQ(std::stod(FindValue(values, key)->value), held) << key;
  }
  EXPECT_EQ(FindValue(values, "unset")->value, "0.30000000000000004");
  EXPECT_EQ(FindValue(values, "tiny")->value, "1e-05");
  EXPECT_EQ(FindValue(values, "f")->value, "0.1");  // the float's own shortest text
  EXPECT_EQ(FindValue(values, "flag")->value, "true");
  EXPECT_EQ(FindValue(values, "id")->value, "9007199254740993");  // beyond a double's integers
  EXPECT_EQ(FindValue(values, "offset")->value, "[0, -0.045, 1.5]");
  EXPECT_EQ(FindValue(values, "q")->value, "[1, 0, 0, 0]");
  // The text is YAML: read back as a document it gives the same values.
  std::string yaml;
  for (const ConfigValue& v : values) yaml += v.key + ": " + v.value + "\n";
  const ConfigNode again = ConfigNode::FromString(yaml, "again.yaml");
  Eigen::Vector3d offset_again = Eigen::Vector3d::Zero();
  double third_again = 0.0;
  again.Read("offset", &offset_again);
  again.Read("third", &third_again);
  EXPECT_EQ(offset_again, offset);
  EXPECT_EQ(third_again, third);
}

TEST(ConfigEffectiveValues, AKeyReadTwiceKeepsItsPlaceAndItsLatestValue) {
  const ConfigNode root = ConfigNode::FromString("x: 1\ny: 2\n", "test.yaml");
  int x = 0, y = 0;
  std::string x_text;
  root.Read("x", &x);
  root.Read("y", &y);
  root.Read("x", &x_text);
  const std::vector<ConfigValue> values = root.EffectiveValues();
  ASSERT_EQ(values.size(), 2u);
  EXPECT_EQ(values[0].key, "x");
  EXPECT_EQ(values[0].value, "1");
  EXPECT_EQ(values[1].key, "y");
}

TEST(ConfigEffectiveValues, IncludedFilesFollowWithTheirOwnName) {
  const std::string path = ::testing::TempDir() + "/kestrel_included_vehicle.yaml";
  {
    std::ofstream out(path);
    out << "mass_kg: 1.5\n";
  }
  const ConfigNode root = ConfigNode::FromString("vehicle_file: v.yaml\n", "sim.yaml");
  std::string vehicle_file;
  root.Read("vehicle_file", &vehicle_file);
  const ConfigNode vehicle = root.Include(path);
  double mass = 0.0, arm = 0.17, seed = 1.0;
  vehicle.Read("mass_kg", &mass);
  vehicle.Read("arm_m", &arm);
  root.Read("seed", &seed);  // read on the including file after the include: still listed first
  const std::vector<ConfigValue> values = root.EffectiveValues();
  ASSERT_EQ(values.size(), 4u);
  EXPECT_EQ(values[0].file, "sim.yaml");
  EXPECT_EQ(values[1].key, "seed");
  EXPECT_EQ(values[2].file, path);
  EXPECT_EQ(values[2].key, "mass_kg");
  EXPECT_EQ(values[2].source, ConfigSource::kFile);
  EXPECT_EQ(values[3].key, "arm_m");
  EXPECT_EQ(values[3].source, ConfigSource::kDefault);
  ExpectConfigError([&] { (void)root.Include(path + ".missing"); }, {".missing", "cannot open"});
}

}  // namespace
}  // namespace kestrel
