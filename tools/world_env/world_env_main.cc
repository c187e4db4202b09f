// kestrel-world-env: what the process sheets take from a world file, as shell assignments
// (scripts/world-env evaluates them): the map limits, the exploration height and the controller's
// geofence (sim/world.h, WorldGeofence: the one derivation kestrel-mission and the tests use).
#include <cstdio>
#include <string>

#include "common/command_line.h"
#include "common/process.h"
#include "sim/world.h"

namespace {
const char* const kUsage =
    "usage: kestrel-world-env WORLD.yaml\n"
    "Prints, for eval, the world's map limits ($KESTREL_MAP_MIN/MAX, \"[x,y,z]\" in m), its\n"
    "exploration height ($KESTREL_HEIGHT, m) and the controller's geofence around the map\n"
    "($KESTREL_FENCE_MIN/MAX, sim/world.h WorldGeofence), as the process sheets take them.\n";

std::string Vector(const Eigen::Vector3d& v) {
  char text[128];
  std::snprintf(text, sizeof(text), "[%g,%g,%g]", v.x(), v.y(), v.z());
  return text;
}
}  // namespace

int main(int argc, char** argv) {
  std::string world_path;
  return kestrel::RunProcess(
      "kestrel-world-env", argc, argv, kUsage,
      [&](CLI::App& app) { app.add_option("world", world_path)->required(); },
      [&](const kestrel::ProcessArgs&, kestrel::ConfigNode&) {
        const kestrel::World world = kestrel::LoadWorld(world_path);
        const kestrel::Geofence fence = kestrel::WorldGeofence(world);
        std::printf("export KESTREL_MAP_MIN='%s' KESTREL_MAP_MAX='%s' KESTREL_HEIGHT='%g'\n",
                    Vector(world.map_min_m).c_str(), Vector(world.map_max_m).c_str(),
                    world.exploration_height_m);
        std::printf("export KESTREL_FENCE_MIN='%s' KESTREL_FENCE_MAX='%s'\n",
                    Vector(fence.min_m).c_str(), Vector(fence.max_m).c_str());
        return 0;
      });
}
