#include "common/vehicle_prefixes.h"

#include <cctype>

#include "common/check.h"

namespace kestrel {

void ReadVehiclePrefixes(const ConfigNode& node, const std::string& key,
                         std::vector<std::string>* prefixes) {
  if (!node.Has(key)) return;
  prefixes->clear();
  for (const ConfigNode& v : node.Elements(key)) {
    std::string prefix;
    v.ReadRequired("prefix", &prefix);
    prefixes->push_back(prefix);
  }
}

void ValidateVehiclePrefixes(const std::vector<std::string>& prefixes, const std::string& key) {
  KESTREL_THROW_UNLESS(!prefixes.empty() && prefixes.size() <= 16,
                       key << ": " << prefixes.size() << " listed; accepted: 1 to 16");
  for (size_t i = 0; i < prefixes.size(); ++i) {
    for (const char ch : prefixes[i]) {
      KESTREL_THROW_UNLESS(std::isalnum(static_cast<unsigned char>(ch)) || ch == '_',
                           key << "[" << i << "].prefix = '" << prefixes[i]
                               << "': accepted: letters, digits and '_'");
    }
    for (size_t j = 0; j < i; ++j) {
      KESTREL_THROW_UNLESS(prefixes[i] != prefixes[j], key << "[" << j << "] and [" << i
                                                           << "] share the prefix '" << prefixes[i]
                                                           << "'");
    }
  }
}

}  // namespace kestrel
