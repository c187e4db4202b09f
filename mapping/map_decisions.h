#pragma once
/// @file
/// The mapper's recorded decisions (map_decisions_t, docs/design.md §3.6) gathered back into the
/// history of one map: which scans, in which order, with which rays and poses. A mapper life
/// numbers its decisions from 0 and names, in every message, the lives whose decisions the map
/// held when it started (a resumed checkpoint). The map a life leaves is therefore: for each of
/// those lives in order, its first N decisions; then every decision of its own.

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "kestrel/map_decision_t.hpp"
#include "kestrel/map_decisions_t.hpp"

namespace kestrel {

class DecisionHistory {
 public:
  /// Takes one message (in any order; a message seen twice is harmless). A message whose
  /// decisions contradict one already held for the same index, or whose lives disagree with
  /// the life's earlier messages, is refused: false and `why` set, nothing kept from it.
  bool Add(const map_decisions_t& message, std::string* why);

  /// The mapper lives heard, in the order first heard (the last is the mapper that ran last).
  [[nodiscard]] const std::vector<int64_t>& lives() const { return order_; }
  /// Decisions held of life `epoch` (0 if unknown).
  [[nodiscard]] int64_t decisions_of(int64_t epoch) const;

  /// The decisions that made the map of life `epoch`, in order: the resumed lives' first
  /// decisions, then all of the life's own up to the last one heard. Empty, with `why` naming
  /// the first missing index and life, if any of them was not heard (nothing then is certain).
  [[nodiscard]] std::vector<map_decision_t> MapOf(int64_t epoch, std::string* why) const;

 private:
  struct Life {
    std::map<int64_t, map_decision_t> decisions;       // by index
    std::vector<std::pair<int64_t, int64_t>> resumed;  // (epoch, decisions), in order
    bool resumed_known{false};
  };
  std::map<int64_t, Life> lives_;
  std::vector<int64_t> order_;
};

/// True if two decisions are the same (every field, the pose's doubles bit for bit).
[[nodiscard]] bool SameDecision(const map_decision_t& a, const map_decision_t& b);

}  // namespace kestrel
