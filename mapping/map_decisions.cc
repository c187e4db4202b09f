#include "mapping/map_decisions.h"

#include <cstdint>
#include <cstring>

namespace kestrel {

namespace {
// The same double bit for bit (-0 and 0 differ; a NaN equals itself).
bool SameBits(double a, double b) {
  uint64_t x = 0, y = 0;
  std::memcpy(&x, &a, sizeof(x));
  std::memcpy(&y, &b, sizeof(y));
  return x == y;
}
}  // namespace

bool SameDecision(const map_decision_t& a, const map_decision_t& b) {
  bool same = a.channel == b.channel && a.epoch == b.epoch && a.seq == b.seq &&
              a.scan_utime == b.scan_utime && a.action == b.action &&
              a.ray_stride == b.ray_stride && a.reason == b.reason;
  for (int i = 0; i < 3; ++i) same = same && SameBits(a.position_m[i], b.position_m[i]);
  for (int i = 0; i < 4; ++i) same = same && SameBits(a.orientation_wxyz[i], b.orientation_wxyz[i]);
  return same;
}

bool DecisionHistory::Add(const map_decisions_t& m, std::string* why) {
  const std::string who = "mapper epoch " + std::to_string(m.epoch);
  if (m.num_decisions != static_cast<int32_t>(m.decisions.size()) ||
      m.num_lives != static_cast<int32_t>(m.life_epochs.size()) ||
      m.life_epochs.size() != m.life_decisions.size() || m.first_index < 0) {
    *why = who + ": counts that do not match the lists, or a negative first index";
    return false;
  }
  std::vector<std::pair<int64_t, int64_t>> resumed;
  for (size_t k = 0; k < m.life_epochs.size(); ++k) {
    if (m.life_decisions[k] < 0 || m.life_epochs[k] == m.epoch) {
      *why = who + ": resumed life " + std::to_string(m.life_epochs[k]) + " with " +
             std::to_string(m.life_decisions[k]) + " decisions is not a life before it";
      return false;
    }
    resumed.emplace_back(m.life_epochs[k], m.life_decisions[k]);
  }
  const auto found = lives_.find(m.epoch);
  if (found != lives_.end()) {
    const Life& life = found->second;
    if (life.resumed_known && life.resumed != resumed) {
      *why = who + ": its messages name different resumed lives";
      return false;
    }
    for (int32_t i = 0; i < m.num_decisions; ++i) {
      const auto held = life.decisions.find(m.first_index + i);
      if (held != life.decisions.end() && !SameDecision(held->second, m.decisions[i])) {
        *why = who + ": decision " + std::to_string(m.first_index + i) + " heard twice, unlike";
        return false;
      }
    }
  }
  Life& life = lives_[m.epoch];
  if (found == lives_.end()) order_.push_back(m.epoch);
  life.resumed = std::move(resumed);
  life.resumed_known = true;
  for (int32_t i = 0; i < m.num_decisions; ++i) life.decisions[m.first_index + i] = m.decisions[i];
  return true;
}

int64_t DecisionHistory::decisions_of(int64_t epoch) const {
  const auto it = lives_.find(epoch);
  return it == lives_.end() ? 0 : static_cast<int64_t>(it->second.decisions.size());
}

std::vector<map_decision_t> DecisionHistory::MapOf(int64_t epoch, std::string* why) const {
  const auto it = lives_.find(epoch);
  if (it == lives_.end()) {
    *why = "no decision of mapper epoch " + std::to_string(epoch);
    return {};
  }
  std::vector<map_decision_t> out;
  // `count` decisions of life `e` from index 0 (all it has, when count < 0).
  const auto take = [&](int64_t e, int64_t count) {
    const auto life = lives_.find(e);
    if (life == lives_.end()) {
      *why = "no decision of resumed mapper epoch " + std::to_string(e) + " (" +
             std::to_string(count) + " needed)";
      return false;
    }
    const auto& d = life->second.decisions;
    const int64_t n = count >= 0 ? count : (d.empty() ? 0 : d.rbegin()->first + 1);
    for (int64_t i = 0; i < n; ++i) {
      const auto one = d.find(i);
      if (one == d.end()) {
        *why = "decision " + std::to_string(i) + " of mapper epoch " + std::to_string(e) +
               " is missing (" + std::to_string(d.size()) + " of " + std::to_string(n) + " heard)";
        return false;
      }
      out.push_back(one->second);
    }
    return true;
  };
  for (const auto& [e, count] : it->second.resumed) {
    if (!take(e, count)) return {};
  }
  if (!take(epoch, -1)) return {};
  why->clear();
  return out;
}

}  // namespace kestrel
