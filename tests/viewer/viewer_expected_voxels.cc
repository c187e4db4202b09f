// viewer_expected_voxels: the viewer test's oracle. Rebuilds the mapper's 3D map from an LCM log's
// MAP3D snapshots and MAP3D_DELTA messages with mapping/map_replica.h (not the bridge's code) and
// prints how many cells are above the occupancy threshold at the end of the log.
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/lcm_decode.h"
#include "mapping/map_replica.h"

int main(int argc, char** argv) {
  if (argc < 2 || argc > 5) {
    std::fprintf(stderr,
                 "usage: viewer_expected_voxels LOG [THRESHOLD=0.5] [MAP3D] [MAP3D_DELTA]\n"
                 "Prints 'occupied N', 'map_seq S' and 'current 0|1' for the map at the end of "
                 "the log.\n");
    return 2;
  }
  const std::string path = argv[1];
  const double threshold = argc > 2 ? std::atof(argv[2]) : 0.5;
  const std::string map_channel = argc > 3 ? argv[3] : "MAP3D";
  const std::string delta_channel = argc > 4 ? argv[4] : "MAP3D_DELTA";
  lcm::LogFile log(path, "r");
  if (!log.good()) {
    std::fprintf(stderr, "cannot read %s\n", path.c_str());
    return 1;
  }
  std::unique_ptr<kestrel::MapReplica> replica;
  int64_t refused = 0, chunks = 0, deltas = 0;
  std::string error;
  for (const lcm::LogEvent* event = log.readNextEvent(); event != nullptr;
       event = log.readNextEvent()) {
    if (event->channel == map_channel) {
      kestrel::map3d_chunk_t chunk;
      if (!kestrel::GuardedDecode(event->data, static_cast<size_t>(event->datalen), &chunk,
                                  &error)) {
        ++refused;
        continue;
      }
      if (!replica) {
        replica = std::make_unique<kestrel::MapReplica>(
            Eigen::Vector3d(chunk.origin_m[0], chunk.origin_m[1], chunk.origin_m[2]),
            chunk.resolution_m, Eigen::Vector3i(chunk.dims[0], chunk.dims[1], chunk.dims[2]),
            chunk.p_init);
      }
      ++chunks;
      refused += !replica->Apply(chunk, &error);
    } else if (event->channel == delta_channel && replica) {
      kestrel::map3d_delta_t delta;
      if (!kestrel::GuardedDecode(event->data, static_cast<size_t>(event->datalen), &delta,
                                  &error)) {
        ++refused;
        continue;
      }
      ++deltas;
      refused += !replica->Apply(delta, &error);
    }
  }
  if (!replica) {
    std::fprintf(stderr, "no %s message in %s\n", map_channel.c_str(), path.c_str());
    return 1;
  }
  int64_t occupied = 0;
  for (const float p : replica->probabilities()) occupied += p > threshold;
  std::printf("occupied %lld\nmap_seq %lld\ncurrent %d\nchunks %lld\ndeltas %lld\nrefused %lld\n",
              static_cast<long long>(occupied), static_cast<long long>(replica->seq()),
              replica->current() ? 1 : 0, static_cast<long long>(chunks),
              static_cast<long long>(deltas), static_cast<long long>(refused));
  return 0;
}
