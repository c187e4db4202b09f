#pragma once
/// @file
/// Conversions between PiecewisePolynomialTrajectory (seconds, common/trajectory.h) and the
/// TRAJECTORY message trajectory_t (utime, per-segment coefficient rows).

#include <cstdint>
#include <optional>
#include <string>

#include "common/trajectory.h"
#include "kestrel/trajectory_t.hpp"

namespace kestrel {

/// The message for `trajectory` (its start time in s becomes start_utime), stamped with the
/// publisher's sequence number and epoch (common/identity.h).
[[nodiscard]] trajectory_t ToMessage(const PiecewisePolynomialTrajectory& trajectory, int64_t utime,
                                     int64_t seq, int64_t epoch);

/// The trajectory of a message, or std::nullopt with *error set when the message is inconsistent
/// (row counts, sizes, non-finite values, non-positive durations). Never throws.
[[nodiscard]] std::optional<PiecewisePolynomialTrajectory> FromMessage(const trajectory_t& msg,
                                                                       std::string* error);

}  // namespace kestrel
