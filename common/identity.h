#pragma once
/// @file
/// Who published a message (docs/design.md §3.4).
///
/// A publisher epoch names one life of one publisher: every node draws one when it is built and
/// stamps it, beside `seq`, on every message it publishes, so that (channel, epoch, seq) names a
/// message even when a restarted publisher counts `seq` from 0 again. Epochs are random 63-bit
/// values from std::random_device (getrandom), never the wall clock: a vehicle computer without a
/// real-time clock boots at the same time with the same pids every time, and two nodes in one
/// process start in the same microsecond. Consumers compare epochs only for equality.

#include <cstdint>

namespace kestrel {

/// A fresh publisher epoch: positive (1 .. 2^63 - 1), never 0, and different from every other
/// epoch drawn in this process. Thread-safe.
[[nodiscard]] int64_t NewPublisherEpoch();

/// Makes the epochs drawn from now on a fixed function of `seed` (the k-th call after this
/// returns the same value for the same seed), for one-process lockstep runs whose messages must
/// be the same bit for bit (kestrel-mission, docs/design.md §7.5). Real processes never call it.
void SeedPublisherEpochs(uint64_t seed);

}  // namespace kestrel
