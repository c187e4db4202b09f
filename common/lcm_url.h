#pragma once
/// @file
/// The receive buffer an LCM URL asks for, sized to what the host grants (docs/design.md §7.6).
///
/// `udpm://...?recv_buf_size=N` makes LCM call setsockopt(SO_RCVBUF, N); Linux grants
/// 2 x min(N, net.core.rmem_max) and says nothing when it cuts the request. RunProcess sizes the
/// request to the host (N' = min(N, rmem_max)) and logs it once when it had to, so that what a
/// process asks for is what it gets, and a host too small for the sheets' 4 MiB says so.

#include <cstdint>
#include <string>

namespace kestrel {

/// What a URL's receive buffer becomes on a host.
struct ReceiveBufferPlan {
  std::string url;            ///< the URL to open: the input with recv_buf_size sized to the host
  int64_t asked_bytes{-1};    ///< recv_buf_size in the input URL, -1 if it has none
  int64_t request_bytes{-1};  ///< recv_buf_size in `url`, -1 if it has none
  int64_t granted_bytes{-1};  ///< what the kernel gives the socket (2 x request), -1 if unknown
  bool resized{false};        ///< request_bytes < asked_bytes
};

/// Pure: the plan for `url` on a host with net.core.rmem_max = `rmem_max` bytes (< 0: unknown,
/// the URL is kept). Only udpm:// URLs with a positive integer recv_buf_size are resized; every
/// other part of the URL is kept as it is.
[[nodiscard]] ReceiveBufferPlan PlanReceiveBuffer(const std::string& url, int64_t rmem_max);

/// net.core.rmem_max from /proc/sys, -1 if it cannot be read.
[[nodiscard]] int64_t ReadRmemMax();

/// The URL a process opens: `url` or, when it is empty, $LCM_DEFAULT_URL ("" if unset: LCM's own
/// default, which asks for no receive buffer).
[[nodiscard]] std::string EffectiveLcmUrl(const std::string& url);

}  // namespace kestrel
