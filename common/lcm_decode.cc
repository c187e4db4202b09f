#include "common/lcm_decode.h"

#include <cctype>
#include <cstring>
#include <limits>
#include <map>
#include <mutex>
#include <regex>
#include <stdexcept>
#include <vector>

#include "lcmtypes/lcm_schemas.h"

namespace kestrel {

namespace {

// ---- A minimal parser of the LCM type language (enough for lcmtypes/*.lcm) ----

struct Dimension {
  bool is_constant{true};
  int64_t constant{0};
  std::string field;  // name of an earlier integer field holding the length
};

struct Field {
  std::string type;  // primitive name or struct name (package prefix removed)
  std::string name;
  std::vector<Dimension> dims;
};

struct Schema {
  std::string name;
  std::vector<Field> fields;
};

int PrimitiveSize(const std::string& type) {
  if (type == "int8_t" || type == "byte" || type == "boolean") return 1;
  if (type == "int16_t") return 2;
  if (type == "int32_t" || type == "float") return 4;
  if (type == "int64_t" || type == "double") return 8;
  if (type == "string") return -1;
  return 0;  // a struct
}

std::vector<std::string> Tokenize(const std::string& text) {
  std::vector<std::string> tokens;
  size_t i = 0;
  while (i < text.size()) {
    const char c = text[i];
    if (std::isspace(static_cast<unsigned char>(c))) {
      ++i;
    } else if (c == '/' && i + 1 < text.size() && text[i + 1] == '/') {
      while (i < text.size() && text[i] != '\n') ++i;
    } else if (c == '/' && i + 1 < text.size() && text[i + 1] == '*') {
      const size_t end = text.find("*/", i + 2);
      i = end == std::string::npos ? text.size() : end + 2;
    } else if (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.') {
      size_t j = i;
      while (j < text.size() &&
             (std::isalnum(static_cast<unsigned char>(text[j])) || text[j] == '_' ||
              text[j] == '.' || text[j] == '-' || text[j] == '+')) {
        ++j;
      }
      tokens.push_back(text.substr(i, j - i));
      i = j;
    } else {
      tokens.emplace_back(1, c);
      ++i;
    }
  }
  return tokens;
}

Schema Parse(const std::string& file, const std::string& text) {
  const std::vector<std::string> t = Tokenize(text);
  size_t i = 0;
  auto fail = [&](const std::string& why) -> void {
    throw std::runtime_error("lcmtypes/" + file + ": " + why);
  };
  auto expect = [&](const std::string& token) {
    if (i >= t.size() || t[i] != token) fail("expected '" + token + "'");
    ++i;
  };
  Schema schema;
  if (i < t.size() && t[i] == "package") {
    i += 2;
    expect(";");
  }
  expect("struct");
  if (i >= t.size()) fail("missing struct name");
  schema.name = t[i++];
  expect("{");
  while (i < t.size() && t[i] != "}") {
    if (t[i] == "const") {
      while (i < t.size() && t[i] != ";") ++i;
      expect(";");
      continue;
    }
    Field field;
    field.type = t[i++];
    const size_t dot = field.type.rfind('.');
    if (dot != std::string::npos) field.type = field.type.substr(dot + 1);
    if (i >= t.size()) fail("missing field name");
    field.name = t[i++];
    while (i < t.size() && t[i] == "[") {
      ++i;
      if (i >= t.size()) fail("unterminated dimension");
      Dimension d;
      if (std::isdigit(static_cast<unsigned char>(t[i][0]))) {
        d.constant = std::stoll(t[i]);
      } else {
        d.is_constant = false;
        d.field = t[i];
      }
      ++i;
      expect("]");
      field.dims.push_back(d);
    }
    expect(";");
    schema.fields.push_back(field);
  }
  return schema;
}

const std::map<std::string, Schema>& Schemas() {
  static const std::map<std::string, Schema> schemas = [] {
    std::map<std::string, Schema> out;
    for (const LcmSchemaSource& source : LcmSchemaSources()) {
      Schema s = Parse(source.file_name, source.text);
      out.emplace(s.name, std::move(s));
    }
    return out;
  }();
  return schemas;
}

/// Least number of bytes any encoding of `type` can take (used to bound element counts).
int64_t MinSize(const std::string& type) {
  const int prim = PrimitiveSize(type);
  if (prim > 0) return prim;
  if (prim < 0) return 5;  // int32 length + NUL
  const auto it = Schemas().find(type);
  if (it == Schemas().end()) return 1;
  int64_t total = 0;
  for (const Field& f : it->second.fields) {
    bool variable = false;
    int64_t count = 1;
    for (const Dimension& d : f.dims) {
      if (d.is_constant) {
        count *= d.constant;
      } else {
        variable = true;
      }
    }
    if (!variable) total += count * MinSize(f.type);
  }
  return total;
}

class Walker {
 public:
  Walker(const uint8_t* data, size_t size) : data_(data), size_(size) {}

  bool Walk(const std::string& type, std::string* error) {
    const auto it = Schemas().find(type);
    if (it == Schemas().end()) {
      *error = "no schema for type '" + type + "'";
      return false;
    }
    std::map<std::string, int64_t> lengths;  // integer fields seen so far in this struct
    std::map<std::string, LcmLengthField> where_lengths;  // and where they lie
    for (const Field& f : it->second.fields) {
      const std::string where = type + "." + f.name + " at byte " + std::to_string(pos_);
      int64_t count = 1;
      for (const Dimension& d : f.dims) {
        int64_t n = d.constant;
        if (!d.is_constant) {
          const auto len = lengths.find(d.field);
          if (len == lengths.end()) {
            *error = where + ": length field '" + d.field + "' not found";
            return false;
          }
          n = len->second;
          if (fields_ != nullptr) fields_->push_back(where_lengths[d.field]);
        }
        if (n < 0) {
          *error = where + ": negative length " + std::to_string(n);
          return false;
        }
        const int64_t min_size = std::max<int64_t>(1, MinSize(f.type));
        const int64_t room = static_cast<int64_t>(remaining()) / min_size;
        if (n != 0 && count > room / n) {
          *error = where + ": length " + std::to_string(n) + " needs more bytes than the " +
                   std::to_string(remaining()) + " left";
          return false;
        }
        count *= n;
      }
      const int prim = PrimitiveSize(f.type);
      if (prim > 0) {
        const uint64_t bytes = static_cast<uint64_t>(count) * static_cast<uint64_t>(prim);
        if (bytes > remaining()) {
          *error = where + ": truncated (" + std::to_string(bytes) + " bytes needed, " +
                   std::to_string(remaining()) + " left)";
          return false;
        }
        if (f.dims.empty() && (f.type == "int8_t" || f.type == "int16_t" || f.type == "int32_t" ||
                               f.type == "int64_t")) {
          lengths[f.name] = ReadSigned(prim);
          where_lengths[f.name] = LcmLengthField{pos_, prim, false};
        }
        pos_ += bytes;
      } else if (prim < 0) {
        for (int64_t e = 0; e < count; ++e) {
          if (remaining() < 4) {
            *error = where + ": truncated string length";
            return false;
          }
          const int64_t len = ReadSigned(4);
          if (fields_ != nullptr) fields_->push_back(LcmLengthField{pos_, 4, true});
          pos_ += 4;
          if (len < 1 || static_cast<uint64_t>(len) > remaining()) {
            *error = where + ": bad string length " + std::to_string(len) + " (" +
                     std::to_string(remaining()) + " bytes left)";
            return false;
          }
          if (data_[pos_ + len - 1] != 0) {
            *error = where + ": string not NUL-terminated";
            return false;
          }
          if (std::memchr(data_ + pos_, 0, static_cast<size_t>(len - 1)) != nullptr) {
            *error = where + ": NUL byte inside a string";
            return false;
          }
          pos_ += static_cast<size_t>(len);
        }
      } else {
        if (++depth_ > 16) {
          *error = where + ": nesting too deep";
          return false;
        }
        for (int64_t e = 0; e < count; ++e) {
          if (!Walk(f.type, error)) return false;
        }
        --depth_;
      }
    }
    return true;
  }

  [[nodiscard]] size_t pos() const { return pos_; }
  void Skip(size_t n) { pos_ += n; }
  /// Collects every length field met into *fields (none by default).
  void CollectLengthFields(std::vector<LcmLengthField>* fields) { fields_ = fields; }

 private:
  [[nodiscard]] size_t remaining() const { return size_ - pos_; }
  [[nodiscard]] int64_t ReadSigned(int bytes) const {
    uint64_t v = 0;
    for (int b = 0; b < bytes; ++b) v = (v << 8) | data_[pos_ + b];
    const int shift = 64 - 8 * bytes;
    return static_cast<int64_t>(v << shift) >> shift;  // sign-extend (big-endian on the wire)
  }

  const uint8_t* data_;
  size_t size_;
  size_t pos_{0};
  int depth_{0};
  std::vector<LcmLengthField>* fields_{nullptr};
};

}  // namespace

bool CheckLcmBytes(const char* type_name, int64_t hash, const void* data, size_t size,
                   std::string* error) {
  const auto* bytes = static_cast<const uint8_t*>(data);
  if (size > static_cast<size_t>(std::numeric_limits<int>::max())) {
    *error =
        std::string(type_name) + ": message of " + std::to_string(size) + " bytes is too large";
    return false;
  }
  if (bytes == nullptr || size < 8) {
    *error = std::string(type_name) + ": " + std::to_string(size) +
             " bytes, shorter than the fingerprint";
    return false;
  }
  uint64_t wire_hash = 0;
  for (int b = 0; b < 8; ++b) wire_hash = (wire_hash << 8) | bytes[b];
  if (static_cast<int64_t>(wire_hash) != hash) {
    *error =
        std::string(type_name) + ": fingerprint mismatch (another type or version on this channel)";
    return false;
  }
  Walker walker(bytes, size);
  walker.Skip(8);
  std::string reason;
  if (!walker.Walk(type_name, &reason)) {
    *error = std::string(type_name) + ": " + reason;
    return false;
  }
  if (walker.pos() != size) {
    *error = std::string(type_name) + ": " + std::to_string(size - walker.pos()) +
             " unexpected trailing bytes";
    return false;
  }
  return true;
}

std::vector<LcmLengthField> LcmLengthFields(const char* type_name, int64_t hash, const void* data,
                                            size_t size) {
  std::string error;
  if (!CheckLcmBytes(type_name, hash, data, size, &error)) return {};
  std::vector<LcmLengthField> fields;
  Walker walker(static_cast<const uint8_t*>(data), size);
  walker.Skip(8);
  walker.CollectLengthFields(&fields);
  if (!walker.Walk(type_name, &error)) return {};
  return fields;
}

GuardedSubscriptions::~GuardedSubscriptions() {
  for (auto& raw : subscriptions_) lcm_.unsubscribe(raw->subscription);
}

void GuardedSubscriptions::AddRaw(
    const std::string& channel,
    std::function<void(const lcm::ReceiveBuffer*, const std::string&)> callback) {
  auto raw = std::make_unique<Raw>();
  raw->callback = std::move(callback);
  raw->hold = &hold_;
  raw->pattern = channel;
  raw->subscription = lcm_.subscribe(channel, &Raw::Handle, raw.get());
  if (raw->subscription != nullptr) raw->subscription->setQueueCapacity(kQueueCapacity);
  subscriptions_.push_back(std::move(raw));
}

int GuardedSubscriptions::Feed(const std::string& channel, const void* data, size_t size) {
  lcm::ReceiveBuffer rbuf{};
  rbuf.data = const_cast<void*>(data);  // NOLINT(cppcoreguidelines-pro-type-const-cast): read only
  rbuf.data_size = static_cast<uint32_t>(size);
  int matched = 0;
  for (const auto& raw : subscriptions_) {
    if (raw->pattern != channel && !std::regex_match(channel, std::regex(raw->pattern))) continue;
    raw->callback(&rbuf, channel);
    ++matched;
  }
  return matched;
}

}  // namespace kestrel
