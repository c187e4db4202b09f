#pragma once
/// @file
/// The one guarded path for decoding untrusted bytes into Kestrel messages.
///
/// LCM carries no checksum, and lcm-gen 1.3.1's C++ decoder resizes every variable-length array
/// to the length field it reads *before* checking that the buffer holds that many elements (and a
/// string length of 0 or a negative array length is undefined behaviour there). A corrupt or
/// hostile datagram can thus make a process allocate gigabytes or crash. GuardedDecode first walks
/// the bytes with the message's schema (the .lcm text compiled into the build): it checks the type
/// fingerprint, every string length (>= 1, NUL-terminated, within the buffer) and every array
/// dimension (>= 0, and count x minimum element size within the remaining bytes) before lcm-gen's
/// decoder runs. The walk allocates nothing that depends on the claimed lengths.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

namespace kestrel {

/// Checks that `size` bytes at `data` are a well-formed encoding of the Kestrel type named
/// `type_name` (e.g. "pose_t") with fingerprint `hash`. On failure returns false and sets
/// *error to the reason (type, field, offset). No allocation proportional to claimed lengths.
[[nodiscard]] bool CheckLcmBytes(const char* type_name, int64_t hash, const void* data, size_t size,
                                 std::string* error);

/// A length field in an encoded message: the integer giving a variable-length array its element
/// count, or the int32 byte count in front of a string.
struct LcmLengthField {
  size_t offset{0};  ///< of its first byte (big-endian), from the start of the encoding
  int width{4};      ///< bytes: 1, 2, 4 or 8
  bool is_string{false};
};

/// The length fields of the well-formed encoding `data` of `type_name` (fingerprint first), in
/// the order the schema walk meets them; empty when the bytes are malformed. For tools that make
/// malformed messages on purpose (tools/fault, docs/design.md §7.11).
[[nodiscard]] std::vector<LcmLengthField> LcmLengthFields(const char* type_name, int64_t hash,
                                                          const void* data, size_t size);

/// Decodes untrusted bytes into *msg after CheckLcmBytes passes. Returns false (with *error set)
/// when the bytes are malformed; *msg is then unspecified but valid.
template <typename Message>
[[nodiscard]] bool GuardedDecode(const void* data, size_t size, Message* msg, std::string* error) {
  if (!CheckLcmBytes(Message::getTypeName(), Message::getHash(), data, size, error)) return false;
  const int used = msg->decode(data, 0, static_cast<int>(size));
  if (used != static_cast<int>(size)) {
    *error = std::string(Message::getTypeName()) + ": lcm decode failed after the schema check";
    return false;
  }
  return true;
}

/// The subscriptions of one node, each decoding through GuardedDecode. Malformed messages go to
/// `on_error(channel, reason)` and never reach the handler. LCM 1.3.1 has no std::function
/// subscribe, so this owns the callables; destroying it unsubscribes them all.
class GuardedSubscriptions {
 public:
  /// Messages LCM keeps waiting per subscription until the node handles them. LCM's own default
  /// is 30: its receive thread silently drops what comes beyond, which 0.3 s of 100 Hz poses
  /// fill while a node is busy (a map snapshot, a checkpoint, a slow core). 500 holds 5 s of
  /// poses and about 16 s of depth images.
  static constexpr int kQueueCapacity = 500;

  explicit GuardedSubscriptions(lcm::LCM& lcm) : lcm_(lcm) {}
  GuardedSubscriptions(const GuardedSubscriptions&) = delete;
  GuardedSubscriptions& operator=(const GuardedSubscriptions&) = delete;
  ~GuardedSubscriptions();

  using ErrorHandler = std::function<void(const std::string& channel, const std::string& reason)>;
  /// Receives a message's raw bytes while holding (SetHold).
  using HoldHandler =
      std::function<void(const std::string& channel, const void* data, size_t size)>;

  /// Subscribes to `channel` (an LCM regex is allowed, e.g. "DEPTH_.*").
  template <typename Message>
  void Add(const std::string& channel,
           std::function<void(const std::string& channel, const Message& msg)> handler,
           ErrorHandler on_error) {
    AddRaw(channel, [handler = std::move(handler), on_error = std::move(on_error)](
                        const lcm::ReceiveBuffer* rbuf, const std::string& chan) {
      Message msg;
      std::string error;
      if (GuardedDecode(rbuf->data, rbuf->data_size, &msg, &error)) {
        handler(chan, msg);
      } else if (on_error) {
        on_error(chan, error);
      }
    });
  }

  /// Hands bytes that did not come from the socket (a recorded log's event) to every
  /// subscription whose channel pattern matches `channel` (anchored, as LCM matches), exactly as
  /// if they had been received, holding or not. Returns the number of subscriptions matched.
  int Feed(const std::string& channel, const void* data, size_t size);
  /// While `hold` is set, messages received from the socket go to it, raw, instead of being
  /// decoded and handled (a node catching up from a log keeps its live input aside); an empty
  /// function ends holding.
  void SetHold(HoldHandler hold) { hold_ = std::move(hold); }

 private:
  struct Raw {
    std::function<void(const lcm::ReceiveBuffer*, const std::string&)> callback;
    lcm::Subscription* subscription{nullptr};
    const HoldHandler* hold{nullptr};  // the owner's
    std::string pattern;
    void Handle(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
      if (hold != nullptr && *hold) {
        (*hold)(channel, rbuf->data, static_cast<size_t>(rbuf->data_size));
        return;
      }
      callback(rbuf, channel);
    }
  };
  void AddRaw(const std::string& channel,
              std::function<void(const lcm::ReceiveBuffer*, const std::string&)> callback);

  lcm::LCM& lcm_;
  std::vector<std::unique_ptr<Raw>> subscriptions_;
  HoldHandler hold_;
};

}  // namespace kestrel
