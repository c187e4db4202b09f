// libFuzzer target: world files (sim/world.h) as kestrel-sim and the tools read them, YAML through
// common/config.h, and the OBJ meshes they name (docs/design.md §7.7). The input is the YAML text,
// optionally followed by a line "#--obj--" and the text every mesh file of the world reads as.
// Properties, beyond no crash and no sanitizer report: a refused world throws ConfigError (bad
// YAML, keys, values) or std::invalid_argument (World::Validate), nothing else; an accepted
// world validates again and its primitives have bounds without NaN.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "common/config.h"
#include "sim/world.h"

namespace {

void Require(bool condition) {
  if (!condition) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  const std::string marker = "\n#--obj--\n";
  const size_t split = input.find(marker);
  const std::string yaml = input.substr(0, split);
  const std::string obj = split == std::string::npos ? "" : input.substr(split + marker.size());
  try {
    const kestrel::WorldMesh mesh = kestrel::ParseObj(obj, "fuzz.obj");
    Require(!mesh.triangles.empty());
    for (const auto& t : mesh.triangles) {
      Require(t.minCoeff() >= 0 && t.maxCoeff() < static_cast<int>(mesh.vertices_W.size()));
    }
  } catch (const kestrel::ConfigError&) {
  }
  try {
    const kestrel::World world =
        kestrel::ParseWorld(kestrel::ConfigNode::FromString(yaml, "worlds/fuzz.yaml"),
                            [&](const std::string& path) { return kestrel::ParseObj(obj, path); });
    world.Validate();
    (void)kestrel::IsInsideObstacle(world, world.start_X_WB.p);
    for (const kestrel::WorldBox& b : world.boxes) {
      const Eigen::AlignedBox3d bounds = kestrel::BoundsOf(b);
      Require(!bounds.min().hasNaN() && !bounds.max().hasNaN());
    }
    for (const kestrel::WorldCylinder& c : world.cylinders) {
      const Eigen::AlignedBox3d bounds = kestrel::BoundsOf(c);
      Require(!bounds.min().hasNaN() && !bounds.max().hasNaN());
    }
  } catch (const kestrel::ConfigError&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
