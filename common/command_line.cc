#include "common/command_line.h"

#include <cmath>
#include <cstdlib>
#include <functional>
#include <sstream>
#include <string>

namespace kestrel::cli {
namespace {

/// A validator that parses the whole text as a finite number and applies `accept`; `what` says
/// what is accepted ("above 0").
CLI::Validator NumberCheck(const std::function<bool(double)>& accept, const std::string& what) {
  return CLI::Validator(
      [accept, what](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (text.empty() || end == nullptr || *end != '\0' || !std::isfinite(v)) {
          return "'" + text + "' is not a number";
        }
        if (!accept(v)) return text + " is not " + what;
        return "";
      },
      "NUMBER " + what);
}

std::string Number(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

}  // namespace

CLI::Validator Positive() {
  return NumberCheck([](double v) { return v > 0.0; }, "above 0");
}

CLI::Validator NonNegative() {
  return NumberCheck([](double v) { return v >= 0.0; }, "0 or more");
}

CLI::Validator Within(double lo, double hi) {
  return NumberCheck([lo, hi](double v) { return v >= lo && v <= hi; },
                     "in [" + Number(lo) + ", " + Number(hi) + "]");
}

}  // namespace kestrel::cli
