#include "drivers/vicon/vicon_bridge.h"

#include "common/clock.h"

namespace kestrel {

ViconBridge::ViconBridge(const ViconConfig& config)
    : config_(config),
      euler_order_(ViconEulerOrder::kIntrinsicXyz),
      latency_us_(SecondsToUtime(config.latency_s)),
      timeout_us_(SecondsToUtime(config.timeout_s)),
      invalid_repeat_us_(SecondsToUtime(config.invalid_repeat_period_s)) {
  config_.Validate();
  euler_order_ = config_.euler_order_enum();
  parse_options_.allow_zero_padding = config_.allow_zero_padding;
  for (const ViconObjectConfig& object : config_.objects) {
    ObjectState state;
    state.config = object;
    if (state.config.child_frame_id.empty()) state.config.child_frame_id = object.name;
    index_by_name_[object.name] = objects_.size();
    objects_.push_back(state);
  }
}

int ViconBridge::num_valid() const {
  int n = 0;
  for (const ObjectState& o : objects_) n += o.valid ? 1 : 0;
  return n;
}

bool ViconBridge::AcceptFrameNumber(uint32_t frame_number) {
  if (!have_frame_) {
    have_frame_ = true;
    last_frame_ = frame_number;
    return true;
  }
  // Modulo 2^32: a forward step is in [1, 2^31), a backward step in [1, 2^31].
  const uint32_t forward = frame_number - last_frame_;
  if (forward == 0) {
    ++stats_.frames_repeated;
    return false;
  }
  if (forward < (uint32_t{1} << 31)) {
    const int64_t missing = int64_t{forward} - 1;
    if (missing > config_.max_frame_gap) {
      ++stats_.stream_restarts;
    } else {
      stats_.frames_dropped += missing;
    }
    last_frame_ = frame_number;
    return true;
  }
  const uint32_t backward = last_frame_ - frame_number;
  if (int64_t{backward} <= config_.reorder_window_frames) {
    ++stats_.frames_late;
    return false;
  }
  ++stats_.stream_restarts;
  last_frame_ = frame_number;
  return true;
}

pose_t ViconBridge::MakePose(ObjectState* state, int64_t utime) const {
  pose_t pose;
  pose.utime = utime;
  pose.seq = state->seq++;
  pose.frame_id = config_.frame_id;
  pose.child_frame_id = state->config.child_frame_id;
  pose.valid = false;
  for (int i = 0; i < 3; ++i) {
    pose.position_m[i] = 0.0;
    pose.velocity_mps[i] = 0.0;
    pose.angular_velocity_radps[i] = 0.0;
  }
  pose.orientation_wxyz[0] = 1.0;
  pose.orientation_wxyz[1] = pose.orientation_wxyz[2] = pose.orientation_wxyz[3] = 0.0;
  pose.has_velocity = false;  // the bridge publishes poses as measured (docs/design.md §2.4)
  return pose;
}

ViconPacketError ViconBridge::HandleDatagram(const uint8_t* data, size_t size,
                                             int64_t receive_utime,
                                             std::vector<ViconPoseOutput>* out,
                                             std::string* reason) {
  ++stats_.datagrams;
  const ViconPacketError error = ParseViconDatagram(data, size, parse_options_, &frame_, reason);
  if (error != ViconPacketError::kNone) {
    ++stats_.malformed;
    ++stats_.malformed_by_kind[ViconPacketErrorName(error)];
    return error;
  }
  if (!AcceptFrameNumber(frame_.frame_number)) return ViconPacketError::kNone;
  ++stats_.frames_accepted;
  const int64_t stamp_utime = receive_utime - latency_us_;  // receive time minus latency
  for (const ViconObject& object : frame_.objects) {
    const auto it = index_by_name_.find(object.name);
    if (it == index_by_name_.end()) {
      ++stats_.unconfigured_objects;
      continue;
    }
    if (config_.zero_pose_is_occluded && object.translation_mm.isZero(0.0) &&
        object.rotation_rad.isZero(0.0)) {
      ++stats_.occluded;
      continue;
    }
    ObjectState& state = objects_[it->second];
    state.valid = true;
    state.last_seen_utime = receive_utime;
    state.last_invalid_utime = -1;
    ViconPoseOutput output;
    output.channel = state.config.channel;
    output.pose = MakePose(&state, stamp_utime);
    output.pose.valid = true;
    const Eigen::Vector3d p_m = object.translation_mm * 1e-3;  // mm -> m
    const Eigen::Quaterniond q = QuaternionFromViconEuler(object.rotation_rad, euler_order_);
    for (int i = 0; i < 3; ++i) output.pose.position_m[i] = p_m[i];
    output.pose.orientation_wxyz[0] = q.w();
    output.pose.orientation_wxyz[1] = q.x();
    output.pose.orientation_wxyz[2] = q.y();
    output.pose.orientation_wxyz[3] = q.z();
    ++stats_.poses_published;
    out->push_back(std::move(output));
  }
  return ViconPacketError::kNone;
}

void ViconBridge::CheckTimeouts(int64_t now_utime, std::vector<ViconPoseOutput>* out) {
  for (ObjectState& state : objects_) {
    bool publish = false;
    if (state.valid) {
      if (now_utime - state.last_seen_utime > timeout_us_) {
        state.valid = false;
        ++stats_.timeouts;
        publish = true;
      }
    } else if (state.last_invalid_utime < 0 ||
               now_utime - state.last_invalid_utime >= invalid_repeat_us_) {
      publish = true;
    }
    if (!publish) continue;
    state.last_invalid_utime = now_utime;
    ViconPoseOutput output;
    output.channel = state.config.channel;
    output.pose = MakePose(&state, now_utime);
    ++stats_.invalid_published;
    out->push_back(std::move(output));
  }
}

}  // namespace kestrel
