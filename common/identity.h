#pragma once
/// @file
/// Who published a message and which run a file belongs to (docs/design.md §3.4, §3.5).
///
/// A publisher epoch names one life of one publisher: every node draws one when it is built and
/// stamps it, beside `seq`, on every message it publishes, so that (channel, epoch, seq) names a
/// message even when a restarted publisher counts `seq` from 0 again. Epochs are random 63-bit
/// values from std::random_device (getrandom), never the wall clock: a vehicle computer without a
/// real-time clock boots at the same time with the same pids every time, and two nodes in one
/// process start in the same microsecond. Consumers compare epochs only for equality.
///
/// A run id names one run of the system (one flight): the mapper writes it into its checkpoint
/// and resumes only a checkpoint of its own run. kestrel-procman gives every command it starts
/// the same $KESTREL_RUN_ID.

#include <cstdint>
#include <string>

namespace kestrel {

/// A fresh publisher epoch: positive (1 .. 2^63 - 1), never 0, and different from every other
/// epoch drawn in this process. Thread-safe.
[[nodiscard]] int64_t NewPublisherEpoch();

/// Makes the epochs drawn from now on a fixed function of `seed` (the k-th call after this
/// returns the same value for the same seed), for one-process lockstep runs whose messages must
/// be the same bit for bit (kestrel-mission, docs/design.md §7.5). Real processes never call it.
void SeedPublisherEpochs(uint64_t seed);

/// A fresh run id, "<UTC yyyymmddThhmmssZ>-<8 random hex digits>", e.g.
/// "20240611T093012Z-5f3a9c01".
[[nodiscard]] std::string NewRunId();

/// "" if `run_id` is a usable run id (1 to 128 characters from A-Z a-z 0-9 . _ : + -), else
/// what is wrong with it.
[[nodiscard]] std::string CheckRunId(const std::string& run_id);

/// The environment variable that carries the run id to the commands of a process sheet.
inline constexpr const char* kRunIdEnvironmentVariable = "KESTREL_RUN_ID";

/// The run id of this process tree: $KESTREL_RUN_ID when it is set and not empty, else a new one
/// (NewRunId()) that is put into this process's environment, so that every child started from
/// now on (and every respawn of one) inherits the same id. @throws std::invalid_argument if
/// $KESTREL_RUN_ID is set to an unusable id (CheckRunId).
std::string EnsureRunIdInEnvironment();

/// The run id a process sheet gave this process: $KESTREL_RUN_ID, "" when unset or empty.
/// @throws std::invalid_argument if it is set to an unusable id (CheckRunId).
[[nodiscard]] std::string RunIdFromEnvironment();

}  // namespace kestrel
