#pragma once
/// @file
/// Checks of a configuration's parameter table (common/param_table.h) for the exploration tests:
/// the loader and the validation refuse the same values, from the one range of each row.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <type_traits>
#include <variant>

#include "common/config.h"
#include "common/param_table.h"

namespace kestrel::test {

/// A row's value in `config`, as a number (flags 0 or 1).
template <class T>
double ParamValue(const T& config, const Param<T>& p) {
  return std::visit([&](auto member) { return static_cast<double>(config.*member); }, p.member);
}

/// Sets a row's value in `config`.
template <class T>
void SetParam(T* config, const Param<T>& p, double v) {
  std::visit(
      [&](auto member) {
        using V = std::decay_t<decltype(config->*member)>;
        config->*member = static_cast<V>(v);
      },
      p.member);
}

/// Each number of the table just outside its row's range is a ConfigError from
/// load("<section>: {<key>: <value>}") and an invalid_argument from validate(config with the
/// value), both naming the key.
template <class T, class Load, class Validate>
void ExpectRangesEnforced(const char* section, const ParamTable<T>& table, const T& valid,
                          Load load, Validate validate) {
  for (const Param<T>& p : table) {
    if (std::holds_alternative<bool T::*>(p.member)) continue;
    SCOPED_TRACE(p.key);
    const double outside = std::isfinite(p.range.min) ? p.range.min - 1.0 : p.range.max + 1.0;
    try {
      (void)load(std::string(section) + ": {" + p.key + ": " + std::to_string(outside) + "}");
      ADD_FAILURE() << "loaded " << outside;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(p.key), std::string::npos) << e.what();
    }
    T bad = valid;
    SetParam(&bad, p, outside);
    try {
      validate(bad);
      ADD_FAILURE() << "validated " << outside;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(p.key), std::string::npos) << e.what();
    }
  }
}

}  // namespace kestrel::test
