#pragma once
/// @file
/// YAML configuration with validation (yaml-cpp). A process loads one file per concern into plain
/// structs (defaults at the members, units in the names) through ConfigNode::Read, which checks
/// each value against its accepted range. Every error is a ConfigError naming the file, the key
/// path, the value and what would be accepted; keys that nothing read are reported by
/// CheckNoUnknownKeys(), never silently ignored.
///
/// Usage:
/// @code
///   const ConfigNode root = ConfigNode::LoadFile("config/mapper.yaml");
///   root.Read("checkpoint_period_s", &config.checkpoint_period_s, Range::AtLeast(0.1));
///   const ConfigNode xtion = root.Child("xtion");            // throws if absent
///   xtion.Read("sigma_m", &config.xtion.sigma_m, Range::Positive());
///   root.CheckNoUnknownKeys();                                 // recursive
/// @endcode
/// Command-line overrides: ApplyOverride("xtion.sigma_m=0.2") before reading.
///
/// Every scalar read is also recorded, present or not: the key path, the value the process runs
/// with (the file's, an override's or the default left in place) and where it came from.
/// EffectiveValues() lists them, with those of the files loaded through Include(), so a process
/// can publish the configuration it really runs with (common/config_publisher.h,
/// docs/design.md §6).

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace kestrel {

/// Where an effective value came from.
enum class ConfigSource : int8_t {
  kDefault = 0,   ///< the key is absent: the value is the code's default
  kFile = 1,      ///< the configuration file
  kOverride = 2,  ///< a --set override (ApplyOverride) of the key or of a section above it
};

/// One value a process read: `value` is YAML text (numbers in their shortest round-trip form,
/// lists as "[a, b, c]", strings as they are).
struct ConfigValue {
  std::string file;  ///< the file it was read from ("(defaults)" when the process had none)
  std::string key;   ///< dotted key path, "sensors[1].sigma_m" style
  std::string value;
  ConfigSource source{ConfigSource::kDefault};
};

/// A configuration error: file, key, value, accepted range. what() is the full sentence.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Accepted interval for a number. Open or closed at each end.
struct Range {
  double min{-std::numeric_limits<double>::infinity()};
  double max{std::numeric_limits<double>::infinity()};
  bool min_inclusive{true};
  bool max_inclusive{true};

  static Range Any() { return {}; }
  static Range Positive() { return {0.0, std::numeric_limits<double>::infinity(), false, true}; }
  static Range NonNegative() { return {0.0, std::numeric_limits<double>::infinity(), true, true}; }
  static Range AtLeast(double lo) {
    return {lo, std::numeric_limits<double>::infinity(), true, true};
  }
  static Range Closed(double lo, double hi) { return {lo, hi, true, true}; }
  /// (lo, hi): both ends excluded, e.g. a probability that must not be 0 or 1.
  static Range Open(double lo, double hi) { return {lo, hi, false, false}; }

  [[nodiscard]] bool Contains(double v) const;
  /// "[0, 1]", "(0, inf)" ...
  [[nodiscard]] std::string ToString() const;
};

/// A node of a YAML document together with the file it came from and its key path. Reads are
/// recorded (shared by all ConfigNodes of one document) so unknown keys can be reported.
class ConfigNode {
 public:
  /// Parses a file; throws ConfigError with the file and the parser's line/column on bad YAML.
  static ConfigNode LoadFile(const std::string& path);
  /// Parses text (tests, --set overrides); `source_name` stands in for the file name in errors.
  static ConfigNode FromString(const std::string& yaml_text, const std::string& source_name);

  /// Applies "a.b.c=value" (value parsed as YAML) to this document; throws ConfigError naming the
  /// override if it is malformed. Creates the key if absent (it is then checked like any other).
  void ApplyOverride(const std::string& assignment);

  /// Loads another file this configuration names (a vehicle file, a world) and attaches it, so
  /// that EffectiveValues() of this document lists its values too. @throws ConfigError
  [[nodiscard]] ConfigNode Include(const std::string& path) const;

  /// Every scalar read so far on this document, in the order first read (a key read twice keeps
  /// its first place and its latest value), then those of the included files.
  [[nodiscard]] std::vector<ConfigValue> EffectiveValues() const;

  [[nodiscard]] bool Has(const std::string& key) const;
  /// A required mapping child; throws ConfigError if missing or not a mapping.
  [[nodiscard]] ConfigNode Child(const std::string& key) const;
  /// The elements of a required (or, if `required` is false, optional: empty) sequence of
  /// mappings; throws ConfigError if an element is not a mapping.
  [[nodiscard]] std::vector<ConfigNode> Elements(const std::string& key,
                                                 bool required = true) const;
  /// The keys of this mapping, in file order. @throws ConfigError on a key that is a sequence or
  /// a mapping (YAML allows them; no Kestrel file has one).
  [[nodiscard]] std::vector<std::string> Keys() const;

  /// Optional scalar reads: an absent key leaves *value (the default) untouched. A present key
  /// that does not parse, is not finite, or is outside `range` throws ConfigError.
  void Read(const std::string& key, double* value, const Range& range = Range::Any()) const;
  void Read(const std::string& key, float* value, const Range& range = Range::Any()) const;
  void Read(const std::string& key, int* value, const Range& range = Range::Any()) const;
  void Read(const std::string& key, int64_t* value, const Range& range = Range::Any()) const;
  void Read(const std::string& key, bool* value) const;
  void Read(const std::string& key, std::string* value) const;
  /// A string that must be one of `choices`.
  void Read(const std::string& key, std::string* value,
            const std::vector<std::string>& choices) const;
  /// A fixed-size list of numbers, each within `range`.
  void Read(const std::string& key, Eigen::Vector3d* value,
            const Range& range = Range::Any()) const;
  void Read(const std::string& key, Eigen::Vector4d* value,
            const Range& range = Range::Any()) const;
  /// A list of strings (scalars), of any length.
  void Read(const std::string& key, std::vector<std::string>* value) const;
  /// A list of numbers of any length (or exactly `size` if size >= 0), each within `range`.
  void Read(const std::string& key, std::vector<double>* value, const Range& range = Range::Any(),
            int size = -1) const;

  /// Required variants: throw ConfigError if the key is absent.
  template <typename T, typename... Extra>
  void ReadRequired(const std::string& key, T* value, const Extra&... extra) const {
    if (!Has(key)) ThrowMissing(key);
    Read(key, value, extra...);
  }

  /// Throws a ConfigError about `key` with `reason` (for cross-field checks in Validate()).
  [[noreturn]] void Fail(const std::string& key, const std::string& reason) const;

  /// Throws ConfigError listing every key under this node that no Read/Child/Elements touched, or
  /// naming the line of a key that is a sequence or a mapping.
  void CheckNoUnknownKeys() const;

  [[nodiscard]] const std::string& file() const;
  /// Dotted key path of this node ("" for the root, "sensors[1].sigma_m" style below).
  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] const YAML::Node& yaml() const { return node_; }

 private:
  struct Document;
  ConfigNode(std::shared_ptr<Document> doc, const YAML::Node& node, std::string path);
  [[nodiscard]] std::string KeyPath(const std::string& key) const;
  [[nodiscard]] YAML::Node Lookup(const std::string& key) const;
  /// Records the value in effect for `key` (read or default) for EffectiveValues().
  void Record(const std::string& key, std::string value) const;
  [[noreturn]] void ThrowMissing(const std::string& key) const;
  [[noreturn]] void ThrowBad(const std::string& key, const YAML::Node& value,
                             const std::string& expected) const;
  void ReadNumber(const std::string& key, double* out, const Range& range, bool integer) const;
  void CollectUnknown(const YAML::Node& node, const std::string& path,
                      std::vector<std::string>* unknown) const;

  std::shared_ptr<Document> doc_;
  YAML::Node node_;
  std::string path_;
};

/// `path` as is if absolute or empty, else root/path (a file named relative to a tool's --root).
[[nodiscard]] std::string PathUnderRoot(const std::string& root, const std::string& path);

}  // namespace kestrel
