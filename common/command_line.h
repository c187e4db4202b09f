#pragma once
/// @file
/// The checks a process's own numeric options use (common/process.h declares them on CLI11),
/// with messages that name the value and the accepted range, e.g.
///   kestrel-cmd: ERROR command line: --height: 'x' is not a number (--help lists the options)
///   kestrel-cmd: ERROR command line: --height: -1 is not above 0 (--help lists the options)
/// Mains include this header for CLI::App and these checks.

#include <CLI/CLI.hpp>

namespace kestrel::cli {

/// A number > 0.
[[nodiscard]] CLI::Validator Positive();
/// A number >= 0.
[[nodiscard]] CLI::Validator NonNegative();
/// A number in [lo, hi].
[[nodiscard]] CLI::Validator Within(double lo, double hi);

}  // namespace kestrel::cli
