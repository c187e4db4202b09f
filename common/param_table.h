#pragma once
/// @file
/// A configuration struct's scalar parameters as one table: each row names the YAML key, the
/// member and the accepted range, so that the loader (ReadParams) and the validation
/// (CheckParams) take the range from one place. Defaults stay at the members (common/config.h);
/// the meaning of each key is the member's doc comment and the reference YAML file's comment.
///
/// Usage:
/// @code
///   const ParamTable<MyConfig> kParams{{
///       {"period_s", &MyConfig::period_s, Range::Positive()},
///       {"retries", &MyConfig::retries, Range::Closed(1, 100)},
///       {"enabled", &MyConfig::enabled},
///   }};
///   ReadParams(node, kParams, &config);           // ConfigError naming file, key, range
///   CheckParams("section", kParams, config);      // std::invalid_argument naming section.key
/// @endcode

#include <sstream>
#include <stdexcept>
#include <type_traits>
#include <variant>
#include <vector>

#include "common/config.h"

namespace kestrel {

/// One scalar parameter of a struct T (a number or a flag).
template <class T>
struct Param {
  const char* key;                                        ///< YAML key in its section
  std::variant<double T::*, int T::*, bool T::*> member;  ///< where it lives
  Range range{Range::Any()};                              ///< accepted values (numbers)
};

/// The rows of one struct's scalar parameters.
template <class T>
using ParamTable = std::vector<Param<T>>;

/// Reads every row's key present under `node` into `config`, each number checked against its
/// row's range. @throws ConfigError naming the file, the key, the value and the range.
template <class T>
void ReadParams(const ConfigNode& node, const ParamTable<T>& table, T* config) {
  for (const Param<T>& p : table) {
    std::visit(
        [&](auto member) {
          if constexpr (std::is_same_v<std::decay_t<decltype(config->*member)>, bool>) {
            node.Read(p.key, &(config->*member));
          } else {
            node.Read(p.key, &(config->*member), p.range);
          }
        },
        p.member);
  }
}

/// Checks every number of `config` against its row's range. @throws std::invalid_argument
/// "<section>.<key> = <value>, accepted <range>" for the first that is outside.
template <class T>
void CheckParams(const char* section, const ParamTable<T>& table, const T& config) {
  for (const Param<T>& p : table) {
    std::visit(
        [&](auto member) {
          using V = std::decay_t<decltype(config.*member)>;
          if constexpr (!std::is_same_v<V, bool>) {
            const double v = static_cast<double>(config.*member);
            if (!p.range.Contains(v)) {
              std::ostringstream s;
              s << section << "." << p.key << " = " << v << ", accepted " << p.range.ToString();
              throw std::invalid_argument(s.str());
            }
          }
        },
        p.member);
  }
}

}  // namespace kestrel
