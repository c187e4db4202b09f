#pragma once
/// @file
/// A small state file that ties a process's flight state to a run (docs/design.md §3.5): what a
/// process respawned within the same run needs to take up where its predecessor stopped (the
/// controller's flight mode, the explorer's take-off point). Text, one "key value" pair a line:
///
///   kestrel-state <kind> 1
///   run_id <run id>
///   <key> <value>
///   ...
///
/// Written atomically: a temporary file beside it (`<path>.tmp`) is written and renamed over the
/// file, so a reader sees the old file or the new one, never a mix (a kill -9 in the middle
/// leaves the temporary file behind, which the next write replaces). Not fsynced: the file must
/// outlive the process, not the machine (a vehicle whose computer loses power falls anyway), and
/// the controller writes it from its control loop. A file of
/// another kind, another version, without a run id or with a malformed line is refused as
/// corrupt, with the reason; a file of another run is reported as such and never used.

#include <map>
#include <string>

namespace kestrel {

/// The contents of a run-state file.
struct RunStateFile {
  std::string kind;                           ///< what wrote it ("controller", "explorer")
  std::string run_id;                         ///< the run it belongs to (common/identity.h)
  std::map<std::string, std::string> values;  ///< key -> value (no spaces in keys or values)

  /// The value of `key`, or nullptr.
  [[nodiscard]] const std::string* Find(const std::string& key) const;
  /// The value of `key` as a finite double into *out; false if absent or not a finite number.
  bool GetDouble(const std::string& key, double* out) const;
};

/// Writes `state` to `path` atomically (file comment), making the folder holding it if it is
/// missing (one level). Keys and values must be non-empty and hold no whitespace. Returns false
/// with *error (the path and the system's reason) on failure.
bool WriteRunStateFile(const std::string& path, const RunStateFile& state, std::string* error);

/// What ReadRunStateFile found.
enum class RunStateRead {
  kOk,        ///< the file of `kind` for `run_id`: *out filled
  kAbsent,    ///< no file at `path`
  kCorrupt,   ///< unreadable or malformed (*error says why)
  kOtherRun,  ///< well-formed, but of another run (*error names it; *out filled)
};

/// Reads the state file of `kind` at `path` for `run_id`. *error (may be nullptr) explains
/// everything but kOk.
RunStateRead ReadRunStateFile(const std::string& path, const std::string& kind,
                              const std::string& run_id, RunStateFile* out, std::string* error);

}  // namespace kestrel
