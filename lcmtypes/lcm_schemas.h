#pragma once
/// @file
/// The text of every lcmtypes/*.lcm file, compiled into the build (see lcmtypes/CMakeLists.txt).

#include <string>
#include <vector>

namespace kestrel {

struct LcmSchemaSource {
  const char* file_name;  ///< e.g. "kestrel_pose_t.lcm"
  const char* text;       ///< the file's contents
};

/// All Kestrel message schemas, in the order listed in lcmtypes/CMakeLists.txt.
const std::vector<LcmSchemaSource>& LcmSchemaSources();

}  // namespace kestrel
