#include "common/config.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

namespace kestrel {

namespace {
std::string FormatNumber(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  std::ostringstream s;
  s << v;
  return s.str();
}

// The shortest text that reads back as the same double ("0.1", "1e-05", "300").
std::string RoundTrip(double v) {
  if (std::isnan(v)) return ".nan";
  if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), v);
  return std::string(buffer, result.ptr);
}

// The shortest text that reads back as the same float ("0.1", not "0.10000000149011612").
std::string RoundTrip(float v) {
  if (!std::isfinite(v)) return RoundTrip(static_cast<double>(v));
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), v);
  return std::string(buffer, result.ptr);
}

template <typename Numbers>
std::string RoundTripList(const Numbers& values) {
  std::string out = "[";
  for (int i = 0; i < static_cast<int>(values.size()); ++i) {
    out += (i ? ", " : "") + RoundTrip(static_cast<double>(values[i]));
  }
  return out + "]";
}

std::string Describe(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull()) return "(null)";
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  YAML::Emitter out;
  out << YAML::Flow << node;
  return out.c_str();
}

std::string LineOf(const YAML::Node& node) {
  if (!node.IsDefined()) return "";  // an absent key has no position (and Mark() would throw)
  const YAML::Mark mark = node.Mark();
  if (mark.line < 0) return "";
  return " (line " + std::to_string(mark.line + 1) + ")";
}
// A mapping's key as text. YAML allows a sequence or a mapping as a key ("? [a, b]: 1"); no
// Kestrel file has one, and yaml-cpp would throw its own conversion error, so it is refused here
// with the file and line.
std::string KeyText(const YAML::Node& key, const std::string& file) {
  if (!key.IsScalar()) {
    throw ConfigError(file + ": a key" + LineOf(key) + " is a " +
                      (key.IsSequence() ? "sequence"
                       : key.IsMap()    ? "mapping"
                                        : "null") +
                      "; keys must be plain values");
  }
  return key.Scalar();
}
}  // namespace

bool Range::Contains(double v) const {
  if (std::isnan(v)) return false;
  const bool above = min_inclusive ? v >= min : v > min;
  const bool below = max_inclusive ? v <= max : v < max;
  return above && below;
}

std::string Range::ToString() const {
  return std::string(min_inclusive ? "[" : "(") + FormatNumber(min) + ", " + FormatNumber(max) +
         (max_inclusive ? "]" : ")");
}

/// The parsed document, the file name, the set of key paths that were read, the values in
/// effect (EffectiveValues) and the files included from it.
struct ConfigNode::Document {
  std::string file;
  YAML::Node root;
  std::set<std::string> used;
  std::vector<ConfigValue> values;
  std::map<std::string, size_t> value_index;  ///< key path -> index in `values`
  /// Key paths set by ApplyOverride, each with the assignment as given ("a.b=1").
  std::map<std::string, std::string> overridden;
  std::vector<std::shared_ptr<const Document>> included;

  /// The override that set `key_path` or a section or element above it (nullptr: none).
  [[nodiscard]] const std::string* Overridden(std::string key_path) const {
    while (!key_path.empty()) {
      const auto it = overridden.find(key_path);
      if (it != overridden.end()) return &it->second;
      const size_t cut = key_path.find_last_of(".[");
      if (cut == std::string::npos) break;
      key_path.resize(cut);
    }
    return nullptr;
  }
  /// Where the value at `key_path` came from, for an error: " (--set a.b=1)" for an override
  /// (whose YAML was parsed on its own, so its line says nothing), else the file's line.
  [[nodiscard]] std::string Where(const std::string& key_path, const YAML::Node& node) const {
    if (const std::string* assignment = Overridden(key_path)) {
      return " (from --set " + *assignment + ")";
    }
    return LineOf(node);
  }
  void Collect(std::vector<ConfigValue>* out) const {
    out->insert(out->end(), values.begin(), values.end());
    for (const auto& d : included) d->Collect(out);
  }
};

ConfigNode::ConfigNode(std::shared_ptr<Document> doc, const YAML::Node& node, std::string path)
    : doc_(std::move(doc)), node_(node), path_(std::move(path)) {}

ConfigNode ConfigNode::LoadFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open configuration file");
  std::stringstream text;
  text << in.rdbuf();
  return FromString(text.str(), path);
}

ConfigNode ConfigNode::FromString(const std::string& yaml_text, const std::string& source_name) {
  auto doc = std::make_shared<Document>();
  doc->file = source_name;
  try {
    doc->root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(source_name + ": line " + std::to_string(e.mark.line + 1) + ", column " +
                      std::to_string(e.mark.column + 1) + ": invalid YAML: " + e.msg);
  }
  if (doc->root.IsNull()) doc->root = YAML::Node(YAML::NodeType::Map);
  if (!doc->root.IsMap()) {
    throw ConfigError(source_name + ": the top level must be a mapping of keys to values");
  }
  YAML::Node root = doc->root;
  return ConfigNode(doc, root, "");
}

void ConfigNode::ApplyOverride(const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw ConfigError(file() + ": override '" + assignment + "' is not of the form key.path=value");
  }
  const std::string key_path = assignment.substr(0, eq);
  YAML::Node value;
  try {
    value = YAML::Load(assignment.substr(eq + 1));
  } catch (const YAML::Exception& e) {
    throw ConfigError(file() + ": override '" + assignment + "': invalid YAML value: " + e.msg);
  }
  std::vector<std::string> parts;
  std::stringstream ss(key_path);
  for (std::string part; std::getline(ss, part, '.');) {
    if (part.empty())
      throw ConfigError(file() + ": override '" + assignment + "' has an empty key");
    parts.push_back(part);
  }
  // A key of a mapping, or the index of an existing element of a sequence ("sensors.0.name").
  auto element_index = [&](const YAML::Node& sequence, const std::string& part) {
    size_t used = 0;
    int index = -1;
    try {
      index = std::stoi(part, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != part.size() || index < 0 || static_cast<size_t>(index) >= sequence.size()) {
      throw ConfigError(file() + ": override '" + assignment + "': '" + part +
                        "' is not an index of a sequence of " + std::to_string(sequence.size()) +
                        " elements");
    }
    return static_cast<size_t>(index);
  };
  // yaml-cpp nodes are handles: walk with fresh handles, assigning into the tree. The key path
  // is rebuilt in ConfigNode's form ("sensors[0].name") for EffectiveValues.
  std::vector<YAML::Node> chain{node_};
  std::string overridden_path = path_;
  auto extend_path = [&](const YAML::Node& here, const std::string& part) {
    if (here.IsSequence()) {
      overridden_path += "[" + std::to_string(element_index(here, part)) + "]";
    } else {
      overridden_path += (overridden_path.empty() ? "" : ".") + part;
    }
  };
  for (size_t i = 0; i + 1 < parts.size(); ++i) {
    YAML::Node here = chain.back();  // not const: a missing key is created, as the last one is
    extend_path(here, parts[i]);
    YAML::Node next = here.IsSequence() ? here[element_index(here, parts[i])] : here[parts[i]];
    if (next.IsDefined() && !next.IsNull() && !next.IsMap() && !next.IsSequence()) {
      throw ConfigError(file() + ": override '" + assignment + "': '" + parts[i] +
                        "' is neither a mapping nor a sequence");
    }
    chain.push_back(next);
  }
  extend_path(chain.back(), parts.back());
  if (chain.back().IsSequence()) {
    chain.back()[element_index(chain.back(), parts.back())] = value;
  } else {
    chain.back()[parts.back()] = value;
  }
  doc_->overridden[overridden_path] = assignment;
}

ConfigNode ConfigNode::Include(const std::string& path) const {
  ConfigNode included = LoadFile(path);
  doc_->included.push_back(included.doc_);
  return included;
}

std::vector<ConfigValue> ConfigNode::EffectiveValues() const {
  std::vector<ConfigValue> out;
  doc_->Collect(&out);
  return out;
}

void ConfigNode::Record(const std::string& key, std::string value) const {
  const std::string key_path = KeyPath(key);
  const ConfigSource source = !Has(key)                               ? ConfigSource::kDefault
                              : doc_->Overridden(key_path) != nullptr ? ConfigSource::kOverride
                                                                      : ConfigSource::kFile;
  const auto [it, inserted] = doc_->value_index.emplace(key_path, doc_->values.size());
  if (inserted) {
    doc_->values.push_back({doc_->file, key_path, std::move(value), source});
  } else {
    doc_->values[it->second].value = std::move(value);
    doc_->values[it->second].source = source;
  }
}

std::string ConfigNode::KeyPath(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

const std::string& ConfigNode::file() const { return doc_->file; }

bool ConfigNode::Has(const std::string& key) const {
  const YAML::Node n = node_[key];
  return n.IsDefined() && !n.IsNull();
}

YAML::Node ConfigNode::Lookup(const std::string& key) const {
  doc_->used.insert(KeyPath(key));
  return node_[key];
}

void ConfigNode::ThrowMissing(const std::string& key) const {
  throw ConfigError(file() + ": required key '" + KeyPath(key) + "' is missing" + LineOf(node_));
}

void ConfigNode::ThrowBad(const std::string& key, const YAML::Node& value,
                          const std::string& expected) const {
  throw ConfigError(file() + ": key '" + KeyPath(key) + "'" + doc_->Where(KeyPath(key), value) +
                    " has value " + Describe(value) + "; accepted: " + expected);
}

void ConfigNode::Fail(const std::string& key, const std::string& reason) const {
  const YAML::Node n = node_[key];
  throw ConfigError(file() + ": key '" + KeyPath(key) + "'" + doc_->Where(KeyPath(key), n) +
                    (n.IsDefined() ? " = " + Describe(n) : std::string()) + ": " + reason);
}

ConfigNode ConfigNode::Child(const std::string& key) const {
  const YAML::Node n = Lookup(key);
  if (!n.IsDefined() || n.IsNull()) ThrowMissing(key);
  if (!n.IsMap()) ThrowBad(key, n, "a mapping of keys to values");
  return ConfigNode(doc_, n, KeyPath(key));
}

std::vector<ConfigNode> ConfigNode::Elements(const std::string& key, bool required) const {
  const YAML::Node n = Lookup(key);
  std::vector<ConfigNode> out;
  if (!n.IsDefined() || n.IsNull()) {
    if (required) ThrowMissing(key);
    return out;
  }
  if (!n.IsSequence()) ThrowBad(key, n, "a list");
  for (size_t i = 0; i < n.size(); ++i) {
    const std::string element_path = KeyPath(key) + "[" + std::to_string(i) + "]";
    // Every element is read by key, which yaml-cpp cannot do on a scalar or a list.
    if (!n[i].IsMap())
      ThrowBad(key + "[" + std::to_string(i) + "]", n[i], "a mapping of keys to values");
    doc_->used.insert(element_path);
    out.push_back(ConfigNode(doc_, n[i], element_path));
  }
  return out;
}

std::vector<std::string> ConfigNode::Keys() const {
  std::vector<std::string> keys;
  if (!node_.IsMap()) return keys;
  for (const auto& kv : node_) keys.push_back(KeyText(kv.first, file()));
  return keys;
}

void ConfigNode::ReadNumber(const std::string& key, double* out, const Range& range,
                            bool integer) const {
  const YAML::Node n = Lookup(key);
  const std::string expected =
      std::string(integer ? "an integer" : "a number") + " in " + range.ToString();
  if (!n.IsScalar()) ThrowBad(key, n, expected);
  double v = 0.0;
  try {
    if (integer) {
      v = static_cast<double>(n.as<int64_t>());
    } else {
      v = n.as<double>();
    }
  } catch (const YAML::Exception&) {
    ThrowBad(key, n, expected);
  }
  if (!std::isfinite(v) || !range.Contains(v)) ThrowBad(key, n, expected);
  *out = v;
}

void ConfigNode::Read(const std::string& key, double* value, const Range& range) const {
  if (Has(key)) ReadNumber(key, value, range, false);
  Record(key, RoundTrip(*value));
}

void ConfigNode::Read(const std::string& key, float* value, const Range& range) const {
  if (Has(key)) {
    double v = 0.0;
    ReadNumber(key, &v, range, false);
    *value = static_cast<float>(v);
  }
  Record(key, RoundTrip(*value));
}

void ConfigNode::Read(const std::string& key, int* value, const Range& range) const {
  if (Has(key)) {
    double v = 0.0;
    Range r = range;
    r.min = std::max(r.min, static_cast<double>(std::numeric_limits<int>::min()));
    r.max = std::min(r.max, static_cast<double>(std::numeric_limits<int>::max()));
    ReadNumber(key, &v, r, true);
    *value = static_cast<int>(v);
  }
  Record(key, std::to_string(*value));
}

void ConfigNode::Read(const std::string& key, int64_t* value, const Range& range) const {
  if (Has(key)) {
    const YAML::Node n = Lookup(key);
    int64_t v = 0;
    const std::string expected = "an integer in " + range.ToString();
    try {
      v = n.as<int64_t>();
    } catch (const YAML::Exception&) {
      ThrowBad(key, n, expected);
    }
    if (!range.Contains(static_cast<double>(v))) ThrowBad(key, n, expected);
    *value = v;
  }
  Record(key, std::to_string(*value));
}

void ConfigNode::Read(const std::string& key, bool* value) const {
  if (Has(key)) {
    const YAML::Node n = Lookup(key);
    try {
      *value = n.as<bool>();
    } catch (const YAML::Exception&) {
      ThrowBad(key, n, "true or false");
    }
  }
  Record(key, *value ? "true" : "false");
}

void ConfigNode::Read(const std::string& key, std::string* value) const {
  if (Has(key)) {
    const YAML::Node n = Lookup(key);
    if (!n.IsScalar()) ThrowBad(key, n, "a string");
    *value = n.Scalar();
  }
  Record(key, *value);
}

void ConfigNode::Read(const std::string& key, std::string* value,
                      const std::vector<std::string>& choices) const {
  if (Has(key)) {
    const YAML::Node n = Lookup(key);
    std::string accepted = "one of {";
    for (size_t i = 0; i < choices.size(); ++i) accepted += (i ? ", " : "") + choices[i];
    accepted += "}";
    if (!n.IsScalar()) ThrowBad(key, n, accepted);
    const auto chosen = std::find(choices.begin(), choices.end(), n.Scalar());
    if (chosen == choices.end()) ThrowBad(key, n, accepted);
    *value = *chosen;
  }
  Record(key, *value);
}

void ConfigNode::Read(const std::string& key, std::vector<std::string>* value) const {
  if (Has(key)) {
    const YAML::Node n = Lookup(key);
    if (!n.IsSequence()) ThrowBad(key, n, "a list of strings");
    std::vector<std::string> out;
    for (size_t i = 0; i < n.size(); ++i) {
      if (!n[i].IsScalar()) ThrowBad(key, n, "a list of strings");
      out.push_back(n[i].Scalar());
    }
    *value = std::move(out);
  }
  std::string text = "[";
  for (size_t i = 0; i < value->size(); ++i) text += (i ? ", " : "") + (*value)[i];
  Record(key, text + "]");
}

void ConfigNode::Read(const std::string& key, std::vector<double>* value, const Range& range,
                      int size) const {
  if (Has(key)) {
    const YAML::Node n = Lookup(key);
    const std::string expected = (size >= 0 ? "a list of " + std::to_string(size) + " numbers"
                                            : std::string("a list of numbers")) +
                                 " each in " + range.ToString();
    if (!n.IsSequence()) ThrowBad(key, n, expected);
    if (size >= 0 && static_cast<int>(n.size()) != size) ThrowBad(key, n, expected);
    std::vector<double> out;
    for (size_t i = 0; i < n.size(); ++i) {
      double v = 0.0;
      try {
        v = n[i].as<double>();
      } catch (const YAML::Exception&) {
        ThrowBad(key, n, expected);
      }
      if (!std::isfinite(v) || !range.Contains(v)) ThrowBad(key, n, expected);
      out.push_back(v);
    }
    *value = std::move(out);
  }
  Record(key, RoundTripList(*value));
}

void ConfigNode::Read(const std::string& key, Eigen::Vector3d* value, const Range& range) const {
  if (Has(key)) {
    std::vector<double> v;
    Read(key, &v, range, 3);
    *value = Eigen::Vector3d(v[0], v[1], v[2]);
  }
  Record(key, RoundTripList(*value));
}

void ConfigNode::Read(const std::string& key, Eigen::Vector4d* value, const Range& range) const {
  if (Has(key)) {
    std::vector<double> v;
    Read(key, &v, range, 4);
    *value = Eigen::Vector4d(v[0], v[1], v[2], v[3]);
  }
  Record(key, RoundTripList(*value));
}

void ConfigNode::CollectUnknown(const YAML::Node& node, const std::string& path,
                                std::vector<std::string>* unknown) const {
  if (!node.IsMap()) return;
  for (const auto& kv : node) {
    const std::string key = KeyText(kv.first, file());
    const std::string key_path = path.empty() ? key : path + "." + key;
    if (doc_->used.count(key_path) == 0) {
      unknown->push_back(key_path + doc_->Where(key_path, kv.first));
      continue;
    }
    if (kv.second.IsMap()) CollectUnknown(kv.second, key_path, unknown);
    if (kv.second.IsSequence()) {
      for (size_t i = 0; i < kv.second.size(); ++i) {
        const std::string element_path = key_path + "[" + std::to_string(i) + "]";
        if (kv.second[i].IsMap() && doc_->used.count(element_path) != 0) {
          CollectUnknown(kv.second[i], element_path, unknown);
        }
      }
    }
  }
}

void ConfigNode::CheckNoUnknownKeys() const {
  std::vector<std::string> unknown;
  CollectUnknown(node_, path_, &unknown);
  if (unknown.empty()) return;
  std::string list;
  for (size_t i = 0; i < unknown.size(); ++i) list += (i ? ", " : "") + unknown[i];
  throw ConfigError(file() + ": unknown key" + (unknown.size() > 1 ? "s " : " ") + list +
                    " (misspelt, or not used by this process)");
}

std::string PathUnderRoot(const std::string& root, const std::string& path) {
  return path.empty() || path[0] == '/' ? path : root + "/" + path;
}

}  // namespace kestrel
