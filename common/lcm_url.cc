#include "common/lcm_url.h"

#include <cstdlib>
#include <fstream>

namespace kestrel {

ReceiveBufferPlan PlanReceiveBuffer(const std::string& url, int64_t rmem_max) {
  ReceiveBufferPlan plan;
  plan.url = url;
  if (url.rfind("udpm://", 0) != 0) return plan;
  const std::string key = "recv_buf_size=";
  const size_t query = url.find('?');
  if (query == std::string::npos) return plan;
  // The parameter at the start of the query or after an '&', not inside another one's name.
  size_t at = query + 1;
  while (at < url.size() && url.compare(at, key.size(), key) != 0) {
    const size_t amp = url.find('&', at);
    if (amp == std::string::npos) return plan;
    at = amp + 1;
  }
  if (at >= url.size()) return plan;
  const size_t begin = at + key.size();
  const size_t end = std::min(url.find('&', begin), url.size());
  const std::string digits = url.substr(begin, end - begin);
  if (digits.empty() || digits.size() > 15 ||
      digits.find_first_not_of("0123456789") != std::string::npos) {
    return plan;  // LCM refuses or ignores it; nothing to size
  }
  plan.asked_bytes = std::stoll(digits);
  plan.request_bytes = plan.asked_bytes;
  if (plan.asked_bytes <= 0) return plan;
  if (rmem_max > 0 && plan.asked_bytes > rmem_max) {
    plan.request_bytes = rmem_max;
    plan.resized = true;
    plan.url = url.substr(0, begin) + std::to_string(rmem_max) + url.substr(end);
  }
  if (rmem_max > 0) plan.granted_bytes = 2 * plan.request_bytes;
  return plan;
}

int64_t ReadRmemMax() {
  std::ifstream in("/proc/sys/net/core/rmem_max");
  int64_t value = -1;
  if (!(in >> value) || value <= 0) return -1;
  return value;
}

std::string EffectiveLcmUrl(const std::string& url) {
  if (!url.empty()) return url;
  const char* from_environment = std::getenv("LCM_DEFAULT_URL");
  return from_environment != nullptr ? from_environment : "";
}

}  // namespace kestrel
