#pragma once
/// @file
/// Vehicle prefixes (docs/design.md §7.10): each vehicle's channels are its prefix followed by
/// the one-vehicle names ("V1_" + "POSE_VICON"); "" is the one vehicle of a one-vehicle system.
/// The rules and the `vehicles: [{prefix: V1_}, ...]` list that the mapper and the viewer read.

#include <string>
#include <vector>

#include "common/config.h"

namespace kestrel {

/// Reads a list of `{prefix: ...}` maps under `key` into *prefixes (replacing it) when the node
/// has the key; leaves *prefixes as it is otherwise.
void ReadVehiclePrefixes(const ConfigNode& node, const std::string& key,
                         std::vector<std::string>* prefixes);

/// @throws std::invalid_argument unless there are 1 to 16 prefixes, each of letters, digits and
/// '_' only, no two alike. Messages name `key` and the index ("vehicles[1].prefix = ...").
void ValidateVehiclePrefixes(const std::vector<std::string>& prefixes,
                             const std::string& key = "vehicles");

}  // namespace kestrel
