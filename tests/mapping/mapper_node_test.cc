// The mapper node over memq://: determinism, pose synchronisation, bad input, snapshots and
// deltas that rebuild the map, checkpoint resume equal to an uninterrupted run, restarted
// publishers (epochs, docs/design.md §3.4) and run ids (docs/design.md §3.5).
#include "mapping/mapper_node.h"

#include <zlib.h>

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <tuple>

#include <gtest/gtest.h>

#include "common/log_tail.h"
#include "kestrel/heartbeat_t.hpp"
#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/map3d_delta_t.hpp"
#include "kestrel/map_decisions_t.hpp"
#include "kestrel/map_status_t.hpp"
#include "mapping/map_decisions.h"
#include "mapping/map_replica.h"
#include "tests/mapping/synthetic_stream.h"

namespace kestrel {
namespace {

using testing::MakeStream;
using testing::StreamEvent;

MapperConfig SmallConfig() {
  MapperConfig c;
  c.limits.min_m = Eigen::Vector3d(-3.2, -4.2, -0.15);
  c.limits.max_m = Eigen::Vector3d(3.2, 4.2, 2.7);
  c.limits.resolution_m = 0.1;
  c.sensors = DefaultMapperSensors();
  c.snapshot_period_s = 0;
  c.delta_period_s = 0;
  c.snapshot_bytes_per_s = 0;  // PublishSnapshot sends every chunk at once
  return c;
}

/// Publishes the events on the node's channels (memq delivers on handle), processing after each.
/// With publish_due, the node's due map messages go out after each event too (as its loop does).
void Feed(lcm::LCM& lcm, MapperNode& node, SimClock& clock, const std::vector<StreamEvent>& events,
          size_t begin = 0, size_t end = SIZE_MAX, bool publish_due = false) {
  for (size_t i = begin; i < std::min(end, events.size()); ++i) {
    const StreamEvent& e = events[i];
    if (e.utime > clock.NowUtime()) clock.SetUtime(e.utime);
    switch (e.kind) {
      case StreamEvent::Kind::kPose:
        lcm.publish("POSE_VICON", &e.pose);
        break;
      case StreamEvent::Kind::kDepth:
        lcm.publish("DEPTH_XTION", &e.depth);
        break;
      case StreamEvent::Kind::kScan:
        lcm.publish("SCAN_HOKUYO", &e.scan);
        break;
    }
    while (lcm.handleTimeout(0) > 0) {
    }
    node.ProcessPending();
    if (publish_due) {
      node.PublishDue();
      while (lcm.handleTimeout(0) > 0) {
      }
    }
  }
  node.ApplyRemaining();  // the end of the input: the last scans wait for no other stream
}

/// The stream with its depth camera and LIDAR publishers restarted before event `restart_at`:
/// from there on their messages carry `epoch` and a seq counted from 0 again, as a driver
/// respawned by the runner sends them. Poses and every payload are unchanged.
std::vector<StreamEvent> WithSensorRestart(std::vector<StreamEvent> events, size_t restart_at,
                                           int64_t epoch) {
  int64_t depth_seq = 0, scan_seq = 0;
  for (size_t i = restart_at; i < events.size(); ++i) {
    if (events[i].kind == StreamEvent::Kind::kDepth) {
      events[i].depth.epoch = epoch;
      events[i].depth.seq = depth_seq++;
    } else if (events[i].kind == StreamEvent::Kind::kScan) {
      events[i].scan.epoch = epoch;
      events[i].scan.seq = scan_seq++;
    }
  }
  return events;
}

/// A fresh temporary path (the file does not exist).
std::string TempPath(const std::string& name) {
  return ::testing::TempDir() + "kestrel_mapper_node_test_" + std::to_string(::getpid()) + "_" +
         name;
}

bool Exists(const std::string& path) {
  struct stat st {};
  return stat(path.c_str(), &st) == 0;
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

class MapperNodeTest : public ::testing::Test {
 protected:
  MapperConfig config_ = SmallConfig();
  std::vector<StreamEvent> events_ =
      MakeStream(3.0, config_.sensors[0].X_BS, config_.sensors[1].X_BS);
};

TEST_F(MapperNodeTest, SameMessagesGiveTheSameMapBitForBit) {
  uint64_t hashes[2];
  for (int run = 0; run < 2; ++run) {
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode node(lcm, config_, clock);
    Feed(lcm, node, clock, events_);
    hashes[run] = node.map_hash();
    EXPECT_EQ(node.scans_applied(), 60) << "30 depth images and 30 scans in 3 s";
    EXPECT_TRUE(node.applied_every_message());
  }
  EXPECT_EQ(hashes[0], hashes[1]);
}

TEST_F(MapperNodeTest, MapsTheRoomWallsAndFreeSpace) {
  lcm::LCM lcm("memq://");
  SimClock clock;
  MapperNode node(lcm, config_, clock);
  Feed(lcm, node, clock, events_);
  const GridGeometry& g = node.geometry();
  // A cell just inside the wall x = 3 at the sensor height is occupied; the space between the
  // vehicle and that wall is free.
  const auto wall = g.CellOf(Eigen::Vector3d(2.97, 0.0, 0.85));
  const auto free = g.CellOf(Eigen::Vector3d(1.5, 0.0, 0.85));
  ASSERT_TRUE(wall && free);
  EXPECT_GT(node.ProbabilityAt(*wall), 0.5);
  EXPECT_LT(node.ProbabilityAt(*free), 0.05);
  EXPECT_TRUE(std::isfinite(node.entropy_nats()));
}

TEST_F(MapperNodeTest, ScansWaitForThePoseAfterThemAndOldOrGapScansAreSkipped) {
  lcm::LCM lcm("memq://");
  SimClock clock(1000000);
  config_.order_wait_s = 0;  // the pose pairing alone: only the LIDAR sends here
  MapperNode node(lcm, config_, clock);
  // A scan before any pose waits (queued, not skipped).
  const StreamEvent* scan = nullptr;
  for (const auto& e : events_) {
    if (e.kind == StreamEvent::Kind::kScan) {
      scan = &e;
      break;
    }
  }
  ASSERT_NE(scan, nullptr);
  lcm.publish("SCAN_HOKUYO", &scan->scan);
  lcm.handleTimeout(0);
  node.ProcessPending();
  EXPECT_EQ(node.queue_depth(), 1u);
  EXPECT_EQ(node.skipped().total(), 0);
  // Poses bracketing it arrive: it is applied.
  for (const auto& e : events_) {
    if (e.kind == StreamEvent::Kind::kPose && e.utime <= scan->utime + 20000)
      lcm.publish("POSE_VICON", &e.pose);
  }
  while (lcm.handleTimeout(0) > 0) {
  }
  node.ProcessPending();
  EXPECT_EQ(node.scans_applied(), 1);
  // A scan older than the history is skipped as too_old.
  planar_scan_t old = scan->scan;
  old.seq = 100;
  old.utime = scan->utime - 10000000;
  lcm.publish("SCAN_HOKUYO", &old);
  lcm.handleTimeout(0);
  node.ProcessPending();
  EXPECT_EQ(node.skipped().count("too_old"), 1);
  // Motion capture gap: poses 0.5 s apart; a scan between them is skipped as gap.
  pose_t p1 = events_[0].pose, p2 = events_[0].pose;
  p1.utime = scan->utime + 1000000;
  p2.utime = scan->utime + 1500000;
  lcm.publish("POSE_VICON", &p1);
  lcm.publish("POSE_VICON", &p2);
  planar_scan_t gap = scan->scan;
  gap.seq = 101;
  gap.utime = scan->utime + 1250000;
  lcm.publish("SCAN_HOKUYO", &gap);
  while (lcm.handleTimeout(0) > 0) {
  }
  node.ProcessPending();
  EXPECT_EQ(node.skipped().count("gap"), 1);
  EXPECT_FALSE(node.applied_every_message());
}

TEST_F(MapperNodeTest, BadInputIsCountedAndDroppedWithoutChangingTheMap) {
  lcm::LCM lcm("memq://");
  SimClock clock;
  MapperNode node(lcm, config_, clock);
  Feed(lcm, node, clock, events_, 0, 50);
  const uint64_t hash = node.map_hash();
  depth_image_t img = events_[6].depth;  // the first depth image
  ASSERT_EQ(events_[6].kind, StreamEvent::Kind::kDepth);
  int64_t seq = 1000;
  auto send = [&](depth_image_t m) {
    m.seq = seq++;
    lcm.publish("DEPTH_XTION", &m);
    lcm.handleTimeout(0);
    node.ProcessPending();
  };
  depth_image_t wrong_size = img;
  wrong_size.width += 1;
  send(wrong_size);
  depth_image_t zero_fx = img;
  zero_fx.fx_px = 0;
  send(zero_fx);
  depth_image_t bad_encoding = img;
  bad_encoding.encoding = 7;
  send(bad_encoding);
  depth_image_t bad_zlib = img;
  bad_zlib.encoding = depth_image_t::ENCODING_ZLIB_U16;
  send(bad_zlib);
  planar_scan_t neg = events_[7].scan;
  ASSERT_EQ(events_[7].kind, StreamEvent::Kind::kScan);
  neg.seq = 1000;
  neg.ranges_m[3] = -1.0f;
  lcm.publish("SCAN_HOKUYO", &neg);
  pose_t nan_pose = events_[0].pose;
  nan_pose.utime = events_[49].utime + 5000;
  nan_pose.position_m[1] = std::nan("");
  lcm.publish("POSE_VICON", &nan_pose);
  const uint8_t garbage[] = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  lcm.publish("DEPTH_XTION", garbage, sizeof(garbage));
  while (lcm.handleTimeout(0) > 0) {
  }
  node.ProcessPending();
  EXPECT_EQ(node.skipped().count("malformed"), 6);
  EXPECT_EQ(node.map_hash(), hash) << "dropped input must not touch the map";
  // The rest of the stream still applies.
  Feed(lcm, node, clock, events_, 50);
  EXPECT_EQ(node.scans_applied(), 60);
}

TEST_F(MapperNodeTest, ACoveredLensAndAJumpedClockAreSaidAndClaimNothing) {
  // The stream with one depth image covered (every pixel 0) and one LIDAR scan stamped 100 s
  // ahead (its clock jumped), against the stream without the two.
  std::vector<StreamEvent> faulty = events_, clean_events;
  size_t covered_at = 0, jumped_at = 0;
  for (size_t i = 40; i < faulty.size() && (covered_at == 0 || jumped_at == 0); ++i) {
    if (faulty[i].kind == StreamEvent::Kind::kDepth && covered_at == 0) covered_at = i;
    if (faulty[i].kind == StreamEvent::Kind::kScan && jumped_at == 0) jumped_at = i;
  }
  ASSERT_GT(covered_at, 0u);
  ASSERT_GT(jumped_at, 0u);
  depth_image_t& covered = faulty[covered_at].depth;
  covered.encoding = depth_image_t::ENCODING_RAW_U16;
  covered.data.assign(static_cast<size_t>(covered.width) * covered.height * 2, 0);
  covered.data_size = static_cast<int32_t>(covered.data.size());
  faulty[jumped_at].scan.utime += 100000000;
  for (size_t i = 0; i < events_.size(); ++i) {
    if (i != covered_at && i != jumped_at) clean_events.push_back(events_[i]);
  }
  // The shipped camera (a 0 is no evidence): the covered frame applies as invalid pixels.
  // A camera whose 0 is a no-return: the covered frame is dropped.
  for (const bool zero_is_no_return : {false, true}) {
    SCOPED_TRACE(zero_is_no_return ? "0 = no return" : "0 = no evidence");
    MapperConfig config = config_;
    config.sensors[0].model.no_return_informs = zero_is_no_return;
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode node(lcm, config, clock);
    Feed(lcm, node, clock, faulty);
    EXPECT_EQ(node.all_zero_frames(), 1);
    EXPECT_EQ(node.skipped().count("all_zero"), zero_is_no_return ? 1 : 0);
    EXPECT_EQ(node.skipped().count("stamp_ahead"), 1);
    // The jumped stamp is not the input's newest: no other scan's wait expired, nothing was
    // decimated, and the map is the one without the two, bit for bit.
    lcm::LCM clean_lcm("memq://");
    SimClock clean_clock;
    MapperNode clean(clean_lcm, config, clean_clock);
    Feed(clean_lcm, clean, clean_clock, clean_events);
    EXPECT_EQ(node.skipped().total(), zero_is_no_return ? 2 : 1);
    EXPECT_EQ(node.scans_applied(), clean.scans_applied() + (zero_is_no_return ? 0 : 1));
    EXPECT_EQ(node.map_hash(), clean.map_hash());
  }
}

TEST_F(MapperNodeTest, SnapshotThenDeltasRebuildTheMapExactly) {
  lcm::LCM lcm("memq://");
  SimClock clock;
  MapperNode node(lcm, config_, clock);
  const GridGeometry& g = node.geometry();
  MapReplica replica(g.origin_m(), g.resolution_m(),
                     Eigen::Vector3i(g.upper().x, g.upper().y, g.upper().z),
                     config_.occupancy.p_init);
  int refused = 0;
  std::string error;
  GuardedSubscriptions subs(lcm);
  subs.Add<map3d_chunk_t>(
      "MAP3D",
      [&](const std::string&, const map3d_chunk_t& m) { refused += !replica.Apply(m, &error); },
      nullptr);
  subs.Add<map3d_delta_t>(
      "MAP3D_DELTA",
      [&](const std::string&, const map3d_delta_t& m) { refused += !replica.Apply(m, &error); },
      nullptr);
  Feed(lcm, node, clock, events_, 0, 100);
  node.PublishSnapshot();  // a late subscriber's starting point
  while (lcm.handleTimeout(0) > 0) {
  }
  for (size_t start = 100; start < events_.size(); start += 37) {
    Feed(lcm, node, clock, events_, start, start + 37);
    node.PublishDelta();
    while (lcm.handleTimeout(0) > 0) {
    }
  }
  EXPECT_EQ(refused, 0) << error;
  EXPECT_TRUE(replica.current());
  EXPECT_EQ(replica.seq(), node.map_seq());
  const CellIndex dims = node.geometry().upper();
  int64_t compared = 0;
  for (int z = 0; z < dims.z; ++z) {
    for (int y = 0; y < dims.y; ++y) {
      for (int x = 0; x < dims.x; ++x) {
        ASSERT_EQ(replica.At(x, y, z), static_cast<float>(node.ProbabilityAt(CellIndex{x, y, z})))
            << x << " " << y << " " << z;
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 100000);
}

// docs/design.md §3.3, §7.6: small messages, a snapshot's chunks paced on the node's clock with
// deltas going on meanwhile, and a replica that keeps the deltas for the snapshot it assembles
// ends equal to the map; pacing changes nothing in the map.
TEST_F(MapperNodeTest, PacedSnapshotsWithDeltasBetweenTheirChunksRebuildTheMapExactly) {
  MapperConfig config = config_;
  config.map_message_max_bytes = 16384;
  config.snapshot_bytes_per_s = 200000;  // a 16 KB chunk every 80 ms or so
  config.snapshot_period_s = 1.0;
  config.delta_period_s = 0.05;
  lcm::LCM lcm("memq://");
  SimClock clock;
  MapperNode node(lcm, config, clock);
  const GridGeometry& g = node.geometry();
  MapReplica replica(g.origin_m(), g.resolution_m(),
                     Eigen::Vector3i(g.upper().x, g.upper().y, g.upper().z),
                     config.occupancy.p_init);
  std::string error;
  int refused = 0, chunks = 0, deltas_between_chunks = 0;
  int64_t largest_chunk = 0, largest_delta = 0, last_chunk_utime = -1, last_chunk_bytes = 0;
  bool between = false;  // a snapshot's chunks are on their way
  GuardedSubscriptions subs(lcm);
  subs.Add<map3d_chunk_t>(
      "MAP3D",
      [&](const std::string&, const map3d_chunk_t& m) {
        refused += !replica.Apply(m, &error);
        ++chunks;
        largest_chunk = std::max<int64_t>(largest_chunk, m.getEncodedSize());
        const int64_t now = clock.NowUtime();
        if (m.chunk_index > 0) {  // paced: this chunk no sooner than the last one's bytes allow
          EXPECT_GE(now - last_chunk_utime,
                    SecondsToUtime(static_cast<double>(last_chunk_bytes) / 200000.0) - 1);
        }
        last_chunk_utime = now;
        last_chunk_bytes = m.getEncodedSize();
        between = m.chunk_index + 1 < m.num_chunks;
      },
      nullptr);
  subs.Add<map3d_delta_t>(
      "MAP3D_DELTA",
      [&](const std::string&, const map3d_delta_t& m) {
        refused += !replica.Apply(m, &error);
        largest_delta = std::max<int64_t>(largest_delta, m.getEncodedSize());
        deltas_between_chunks += between;
      },
      nullptr);
  Feed(lcm, node, clock, events_, 0, SIZE_MAX, /*publish_due=*/true);
  // 3 s more of the clock: the last snapshot's tail, and the changes left go out.
  for (int i = 0; i < 300; ++i) {
    clock.AdvanceUtime(10000);
    node.PublishDue();
    while (lcm.handleTimeout(0) > 0) {
    }
  }
  EXPECT_FALSE(node.snapshot_in_flight());
  EXPECT_EQ(refused, 0) << error;
  EXPECT_LE(largest_chunk, config.map_message_max_bytes);
  EXPECT_LE(largest_delta, 3 * config.map_message_max_bytes);
  EXPECT_GT(chunks, 20);
  EXPECT_GT(deltas_between_chunks, 0) << "no delta went out while a snapshot was paced";
  ASSERT_TRUE(replica.current());
  EXPECT_EQ(replica.seq(), node.map_seq());
  const CellIndex dims = node.geometry().upper();
  for (int z = 0; z < dims.z; ++z) {
    for (int y = 0; y < dims.y; ++y) {
      for (int x = 0; x < dims.x; ++x) {
        ASSERT_EQ(replica.At(x, y, z), static_cast<float>(node.ProbabilityAt(CellIndex{x, y, z})))
            << x << " " << y << " " << z;
      }
    }
  }
  // Pacing and message sizes change when messages go, never the map.
  lcm::LCM lcm2("memq://");
  SimClock clock2;
  MapperNode unpaced(lcm2, config_, clock2);
  Feed(lcm2, unpaced, clock2, events_);
  EXPECT_EQ(unpaced.map_hash(), node.map_hash());
}

TEST_F(MapperNodeTest, ALostDeltaMakesTheReplicaStaleUntilTheNextSnapshot) {
  lcm::LCM lcm("memq://");
  SimClock clock;
  MapperNode node(lcm, config_, clock);
  const GridGeometry& g = node.geometry();
  MapReplica replica(g.origin_m(), g.resolution_m(),
                     Eigen::Vector3i(g.upper().x, g.upper().y, g.upper().z),
                     config_.occupancy.p_init);
  std::vector<map3d_delta_t> deltas;
  std::string error;
  GuardedSubscriptions subs(lcm);
  subs.Add<map3d_chunk_t>(
      "MAP3D", [&](const std::string&, const map3d_chunk_t& m) { (void)replica.Apply(m, &error); },
      nullptr);
  subs.Add<map3d_delta_t>(
      "MAP3D_DELTA", [&](const std::string&, const map3d_delta_t& m) { deltas.push_back(m); },
      nullptr);
  Feed(lcm, node, clock, events_, 0, 60);
  node.PublishSnapshot();
  for (size_t start = 60; start < 180; start += 40) {
    Feed(lcm, node, clock, events_, start, start + 40);
    node.PublishDelta();
  }
  while (lcm.handleTimeout(0) > 0) {
  }
  ASSERT_EQ(deltas.size(), 3u);
  ASSERT_TRUE(replica.current());
  EXPECT_TRUE(replica.Apply(deltas[0], &error)) << error;
  EXPECT_FALSE(replica.Apply(deltas[2], &error)) << "delta 1 was lost";
  EXPECT_FALSE(replica.current());
  node.PublishSnapshot();
  while (lcm.handleTimeout(0) > 0) {
  }
  EXPECT_TRUE(replica.current());
  EXPECT_EQ(replica.seq(), node.map_seq());
}

TEST_F(MapperNodeTest, CheckpointResumeEqualsAnUninterruptedRun) {
  char path[] = "/tmp/kestrel-mapper-checkpoint-XXXXXX";
  const int fd = mkstemp(path);
  ASSERT_GE(fd, 0);
  close(fd);
  std::remove(path);
  uint64_t uninterrupted = 0;
  {
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode node(lcm, config_, clock);
    Feed(lcm, node, clock, events_);
    uninterrupted = node.map_hash();
  }
  MapperConfig with_checkpoint = config_;
  with_checkpoint.checkpoint_path = path;
  with_checkpoint.run_id = "test-run";  // the same run: the restarted node resumes
  {
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode node(lcm, with_checkpoint, clock);
    Feed(lcm, node, clock, events_, 0, events_.size() / 2);
    ASSERT_TRUE(node.SaveCheckpoint());
    Feed(lcm, node, clock, events_, events_.size() / 2, events_.size() / 2 + 40);  // lost work
  }
  {
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode node(lcm, with_checkpoint, clock);  // resumes
    EXPECT_TRUE(node.resumed());
    Feed(lcm, node, clock, events_);  // the stream again, from the start
    EXPECT_GT(node.skipped().count("already_applied"), 20);
    EXPECT_EQ(node.map_hash(), uninterrupted);
    EXPECT_TRUE(node.applied_every_message());
  }
  // A corrupt checkpoint is refused and moved aside; the node starts empty.
  {
    FILE* f = std::fopen(path, "r+b");
    ASSERT_NE(f, nullptr);
    std::fseek(f, 100, SEEK_SET);
    std::fputc(0x5a, f);
    std::fclose(f);
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode node(lcm, with_checkpoint, clock);
    EXPECT_TRUE(node.sequences().empty());
    FILE* aside = std::fopen((std::string(path) + ".corrupt").c_str(), "rb");
    EXPECT_NE(aside, nullptr);
    if (aside) std::fclose(aside);
  }
  std::remove((std::string(path) + ".corrupt").c_str());
}

// A publisher restarted mid-stream (a new epoch, seq from 0 again) is applied at once: nothing
// is skipped as already applied, and the map equals the one a fresh mapper builds from the same
// messages without the restart. (Compared by seq alone, the restarted sensors' first 15 scans
// each would be dropped and the maps would differ.)
TEST_F(MapperNodeTest, ARestartedPublisherIsAppliedAtOnce) {
  const size_t restart_at = events_.size() / 2;
  const std::vector<StreamEvent> restarted = WithSensorRestart(events_, restart_at, 0x0badcafe);
  size_t first_depth = restart_at;
  while (restarted[first_depth].kind != StreamEvent::Kind::kDepth) ++first_depth;
  ASSERT_EQ(restarted[first_depth].depth.seq, 0);
  ASSERT_GT(events_[first_depth].depth.seq, 10) << "the restart must send seqs seen before";
  uint64_t expected = 0;
  {
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode fresh(lcm, config_, clock);
    Feed(lcm, fresh, clock, events_);
    expected = fresh.map_hash();
  }
  lcm::LCM lcm("memq://");
  SimClock clock;
  MapperNode node(lcm, config_, clock);
  Feed(lcm, node, clock, restarted, 0, restart_at);
  const int64_t before = node.scans_applied();
  EXPECT_GT(before, 10);
  EXPECT_EQ(node.publisher_restarts(), 0);
  Feed(lcm, node, clock, restarted, restart_at);
  EXPECT_EQ(node.scans_applied(), 60);
  EXPECT_EQ(node.skipped().count("already_applied"), 0);
  EXPECT_TRUE(node.applied_every_message());
  EXPECT_EQ(node.publisher_restarts(), 2) << "the depth camera and the LIDAR restarted";
  EXPECT_EQ(node.map_hash(), expected);
  // Both epochs of each sensor are remembered, the new one last.
  for (const char* channel : {"DEPTH_XTION", "SCAN_HOKUYO"}) {
    const auto& epochs = node.sequences().at(channel);
    ASSERT_EQ(epochs.size(), 2u) << channel;
    EXPECT_EQ(epochs[0].epoch, testing::kStreamEpoch) << channel;
    EXPECT_EQ(epochs[1].epoch, 0x0badcafe) << channel;
    EXPECT_EQ(epochs[0].last_seq + 1 + epochs[1].last_seq + 1, 30) << channel;
  }
}

// A mapper restarted from its checkpoint and fed the whole log again (which holds a publisher
// restart) applies every message exactly once: its final map and saved file equal bit for bit
// those of a mapper fed the log once. The log's first epoch precedes the restart, so a rule that
// remembered only each channel's latest epoch would apply its messages twice.
TEST_F(MapperNodeTest, AResumedMapperAppliesAReplayedLogExactlyOnce) {
  const size_t restart_at = events_.size() / 3;
  const std::vector<StreamEvent> log = WithSensorRestart(events_, restart_at, 0x0badcafe);
  const std::string once_path = TempPath("once.kmap");
  const std::string resumed_path = TempPath("resumed.kmap");
  uint64_t once_hash = 0;
  {
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode once(lcm, config_, clock);
    Feed(lcm, once, clock, log);
    ASSERT_EQ(once.scans_applied(), 60);
    once_hash = once.map_hash();
    once.SaveMapFile(once_path);
  }
  MapperConfig with_checkpoint = config_;
  with_checkpoint.checkpoint_path = TempPath("replay-checkpoint.kmap");
  with_checkpoint.run_id = "replay-run";
  int64_t in_checkpoint = 0;
  {
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode first(lcm, with_checkpoint, clock);
    Feed(lcm, first, clock, log, 0, 2 * log.size() / 3);  // past the restart
    ASSERT_TRUE(first.SaveCheckpoint());
    in_checkpoint = first.scans_applied();
    ASSERT_EQ(first.sequences().at("DEPTH_XTION").size(), 2u);
    Feed(lcm, first, clock, log, 2 * log.size() / 3, 2 * log.size() / 3 + 50);  // lost work
  }
  lcm::LCM lcm("memq://");
  SimClock clock;
  MapperNode resumed(lcm, with_checkpoint, clock);
  ASSERT_TRUE(resumed.resumed());
  Feed(lcm, resumed, clock, log);  // the whole log again
  EXPECT_EQ(in_checkpoint + resumed.scans_applied(), 60) << "every message exactly once";
  EXPECT_EQ(resumed.skipped().count("already_applied"), in_checkpoint);
  EXPECT_EQ(resumed.publisher_restarts(), 0) << "both epochs were in the checkpoint";
  EXPECT_TRUE(resumed.applied_every_message());
  EXPECT_EQ(resumed.map_hash(), once_hash);
  resumed.SaveMapFile(resumed_path);
  EXPECT_TRUE(ReadAll(resumed_path) == ReadAll(once_path)) << "the saved map files differ";
  for (const std::string& p : {once_path, resumed_path, with_checkpoint.checkpoint_path}) {
    std::remove(p.c_str());
  }
}

/// The events in the order a mapper receives them when the LIDAR's driver process relays its
/// scans `delay_us` later than the camera's driver relays its images (stable otherwise).
std::vector<StreamEvent> WithScansDelayed(std::vector<StreamEvent> events, int64_t delay_us) {
  auto arrival = [delay_us](const StreamEvent& e) {
    return e.utime + (e.kind == StreamEvent::Kind::kScan ? delay_us : 0);
  };
  std::stable_sort(events.begin(), events.end(), [&](const StreamEvent& a, const StreamEvent& b) {
    return arrival(a) < arrival(b);
  });
  return events;
}

// Scans apply in (stamp, vehicle, sensor) order once every sensor stream has passed them
// (docs/design.md §3.6): the LIDAR relayed 250 ms behind the camera gives the same map as both on
// time. In arrival order (order_wait_s = 0) the two maps differ.
TEST_F(MapperNodeTest, ScansApplyInStampOrderWhateverTheDelayBetweenSensors) {
  const std::vector<StreamEvent> late = WithScansDelayed(events_, 250000);
  ASSERT_NE(late[0].utime, events_[0].utime + 1) << "keeps the test honest: orders differ";
  auto run = [&](double order_wait_s, const std::vector<StreamEvent>& events) {
    MapperConfig c = config_;
    c.order_wait_s = order_wait_s;
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode node(lcm, c, clock);
    Feed(lcm, node, clock, events);
    EXPECT_EQ(node.scans_applied(), 60);
    EXPECT_TRUE(node.applied_every_message());
    return node.map_hash();
  };
  EXPECT_EQ(run(0.3, late), run(0.3, events_));
  EXPECT_NE(run(0.0, late), run(0.0, events_)) << "arrival order: the delay changes the map";
}

// A calibrated mount and stamp offset (docs/algorithms.md §3.7) move the pairing: each scan is
// cast from the pose interpolated at its stamp less the offset, times X_BS * (Exp(w), p); without
// them the pose at the stamp times X_BS, bit for bit.
TEST_F(MapperNodeTest, CalibratedMountAndStampOffsetMoveThePairing) {
  const auto applied = [&](const MapperConfig& c) {
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode node(lcm, c, clock);
    std::vector<MapperNode::AppliedScan> scans;
    node.SetScanObserver([&](const MapperNode::AppliedScan& s) { scans.push_back(s); });
    PoseHistory observed(PoseHistoryConfig{100.0, 0.1, 0.2});
    node.SetPoseObserver([&](size_t vehicle, int64_t utime, const Pose3& X_WB) {
      EXPECT_EQ(vehicle, 0u);
      EXPECT_TRUE(observed.Add(utime, X_WB));
    });
    Feed(lcm, node, clock, events_);
    EXPECT_EQ(node.scans_applied(), 60);
    EXPECT_GT(observed.size(), 290u);  // every pose of the 3 s at 100 Hz
    return scans;
  };
  // The oracle: the poses of the stream, interpolated as the mapper's PoseHistory does.
  PoseHistory poses(PoseHistoryConfig{100.0, 0.1, 0.2});
  for (const StreamEvent& e : events_) {
    if (e.kind != StreamEvent::Kind::kPose) continue;
    Pose3 X_WB;
    X_WB.p = Eigen::Vector3d(e.pose.position_m[0], e.pose.position_m[1], e.pose.position_m[2]);
    ASSERT_TRUE(QuaternionFromWxyz(e.pose.orientation_wxyz, &X_WB.q));
    poses.Add(e.utime, X_WB);
  }
  const auto pose_at = [&](int64_t utime) {
    Pose3 X_WB;
    EXPECT_EQ(poses.Lookup(utime, utime, &X_WB), PoseLookupResult::kOk) << utime;
    return X_WB;
  };
  const auto plain = applied(config_);
  ASSERT_EQ(plain.size(), 60u);
  for (const auto& s : plain) {
    EXPECT_EQ(s.pose_utime, s.utime);
    const Pose3 expected = pose_at(s.utime) * config_.sensors[s.sensor].X_BS;
    EXPECT_EQ(s.X_WS.p, expected.p);
    EXPECT_EQ(s.X_WS.q.coeffs(), expected.q.coeffs());
  }
  MapperConfig calibrated = config_;
  calibrated.sensors[0].stamp_offset_s = 0.015;
  calibrated.sensors[0].mount_correction_m = Eigen::Vector3d(0.004, -0.002, 0.003);
  calibrated.sensors[0].mount_correction_rad = Eigen::Vector3d(0.01, -0.005, 0.002);
  calibrated.sensors[1].stamp_offset_s = -0.002;
  const auto moved = applied(calibrated);
  ASSERT_EQ(moved.size(), 60u);
  for (const auto& s : moved) {
    const MapperSensorConfig& sensor = calibrated.sensors[s.sensor];
    EXPECT_EQ(s.pose_utime, s.utime - std::llround(sensor.stamp_offset_s * 1e6));
    const Eigen::Quaterniond q_C(Eigen::AngleAxisd(sensor.mount_correction_rad.norm(),
                                                   sensor.mount_correction_rad.normalized()));
    const Pose3 expected = pose_at(s.pose_utime) * sensor.X_BS *
                           (s.sensor == 0 ? Pose3{sensor.mount_correction_m, q_C} : Pose3{});
    EXPECT_LT((s.X_WS.p - expected.p).norm(), 1e-12);
    EXPECT_LT(s.X_WS.q.angularDistance(expected.q), 1e-12);
  }
  EXPECT_GT((moved[0].X_WS.p - plain[0].X_WS.p).norm(), 0.002);
  // Out of range: refused with the key named.
  calibrated.sensors[0].mount_correction_m.x() = 0.2;
  EXPECT_THROW(
      {
        try {
          calibrated.Validate();
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find("mount_correction_m"), std::string::npos);
          throw;
        }
      },
      std::invalid_argument);
}

// Messages lost between a publisher and the mapper (the network, a full queue) show as gaps in
// their publisher's seq: each is counted as lost_in_transport, and a restart (a new epoch from
// seq 0) is not a gap.
TEST_F(MapperNodeTest, SeqGapsAreCountedAsLostInTransport) {
  std::vector<StreamEvent> events = WithSensorRestart(events_, events_.size() / 2, 0x0badcafe);
  int depth_seen = 0;
  std::vector<StreamEvent> lossy;
  for (const StreamEvent& e : events) {
    if (e.kind == StreamEvent::Kind::kDepth && ++depth_seen >= 5 && depth_seen <= 7) continue;
    lossy.push_back(e);
  }
  lcm::LCM lcm("memq://");
  SimClock clock;
  MapperNode node(lcm, config_, clock);
  Feed(lcm, node, clock, lossy);
  EXPECT_EQ(node.skipped().count("lost_in_transport"), 3);
  EXPECT_EQ(node.scans_applied(), 57);
  EXPECT_FALSE(node.applied_every_message());
}

/// The message of an event, encoded, with its channel: what lcm-logger writes.
std::pair<std::string, std::vector<uint8_t>> Encoded(const StreamEvent& e) {
  auto encode = [](const auto& msg) {
    std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
    msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    return bytes;
  };
  switch (e.kind) {
    case StreamEvent::Kind::kPose:
      return {"POSE_VICON", encode(e.pose)};
    case StreamEvent::Kind::kDepth:
      return {"DEPTH_XTION", encode(e.depth)};
    case StreamEvent::Kind::kScan:
    default:
      return {"SCAN_HOKUYO", encode(e.scan)};
  }
}

/// Appends events [begin, end) to the run's log and flushes it, as lcm-logger does.
void Log(lcm::LogFile& log, const std::vector<StreamEvent>& events, size_t begin, size_t end) {
  for (size_t i = begin; i < end; ++i) {
    auto [channel, bytes] = Encoded(events[i]);
    lcm::LogEvent le;
    le.eventnum = static_cast<int64_t>(i);
    le.timestamp = events[i].utime;
    le.channel = channel;
    le.datalen = static_cast<int32_t>(bytes.size());
    le.data = bytes.data();
    ASSERT_EQ(log.writeEvent(&le), 0);
  }
  std::fflush(log.getFilePtr());
}

// A mapper killed with -9 and respawned catches up from the run's log (docs/design.md §3.6): it
// resumes its last checkpoint, holds its live input aside while it reads the log from the
// start, and hands over where the log reaches the held messages. The map is the one a mapper
// that never stopped holds, every scan applied once. Without the catch-up, the scans sent while it
// was down are missing and the map differs.
TEST_F(MapperNodeTest, ARespawnedMapperCatchesUpFromTheRunsLog) {
  const size_t n = events_.size();
  uint64_t uninterrupted = 0;
  {
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode node(lcm, config_, clock);
    Feed(lcm, node, clock, events_);
    ASSERT_EQ(node.scans_applied(), 60);
    uninterrupted = node.map_hash();
  }
  MapperConfig c = config_;
  c.checkpoint_path = TempPath("catch-up.kmap");
  c.run_id = "catch-up-run";
  const std::string log_path = TempPath("catch-up.lcmlog");
  for (const bool catch_up : {true, false}) {
    SCOPED_TRACE(catch_up ? "with the catch-up" : "without");
    std::remove(c.checkpoint_path.c_str());
    lcm::LogFile log(log_path, "w");
    ASSERT_TRUE(log.good());
    int64_t in_checkpoint = 0;
    {
      lcm::LCM lcm("memq://");
      SimClock clock;
      MapperNode first(lcm, c, clock);
      Feed(lcm, first, clock, events_, 0, n / 3);
      ASSERT_TRUE(first.SaveCheckpoint());
      in_checkpoint = first.scans_applied();
      Feed(lcm, first, clock, events_, n / 3, n / 2);  // applied, then lost with the process
    }
    Log(log, events_, 0, 6 * n / 10);  // the logger went on while the mapper was down
    lcm::LCM lcm("memq://");
    SimClock clock(events_[6 * n / 10].utime);
    MapperNode respawned(lcm, c, clock);
    ASSERT_TRUE(respawned.resumed());
    if (!catch_up) {
      Feed(lcm, respawned, clock, events_, 6 * n / 10 - 20, n);
      EXPECT_NE(respawned.map_hash(), uninterrupted);
      continue;
    }
    respawned.BeginCatchUp();
    // Live input from before the log's end (the logger had them already), held aside.
    Feed(lcm, respawned, clock, events_, 6 * n / 10 - 20, 6 * n / 10 + 30);
    EXPECT_EQ(respawned.scans_applied(), 0) << "live input is held while catching up";
    LogTail tail(log_path);
    while (const std::optional<LoggedEvent> e = tail.Next()) {
      respawned.FeedCatchUp(e->channel, e->data.data(), e->data.size());
    }
    EXPECT_TRUE(respawned.catch_up_overlaps());
    Log(log, events_, 6 * n / 10, 6 * n / 10 + 10);  // flushed meanwhile
    while (const std::optional<LoggedEvent> e = tail.Next()) {
      respawned.FeedCatchUp(e->channel, e->data.data(), e->data.size());
    }
    const MapperNode::CatchUpResult r = respawned.EndCatchUp();
    EXPECT_TRUE(r.overlapped);
    EXPECT_EQ(r.fed, static_cast<int64_t>(6 * n / 10 + 10));
    EXPECT_EQ(r.held, 50);
    EXPECT_EQ(r.repeated, 30) << "held messages also read from the log are not handled twice";
    Feed(lcm, respawned, clock, events_, 6 * n / 10 + 30, n);
    EXPECT_EQ(in_checkpoint + respawned.scans_applied(), 60) << "every scan exactly once";
    EXPECT_TRUE(respawned.applied_every_message());
    EXPECT_EQ(respawned.map_hash(), uninterrupted);
  }
  std::remove(c.checkpoint_path.c_str());
  std::remove(log_path.c_str());
}

// A checkpoint of another run is not resumed: it is moved aside (never overwritten, nor a
// second one over the first) and the map starts empty; with resume = any it is resumed. A
// mapper without a run id gets a fresh one, so it resumes nothing either.
TEST_F(MapperNodeTest, AnotherRunsCheckpointIsNotResumedUnlessAsked) {
  const std::string path = TempPath("runs.kmap");
  MapperConfig flight1 = config_;
  flight1.checkpoint_path = path;
  flight1.run_id = "flight-1";
  uint64_t empty_hash = 0, flight1_hash = 0;
  StreamSequences flight1_sequences;
  {
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode node(lcm, flight1, clock);
    EXPECT_FALSE(node.resumed());
    empty_hash = node.map_hash();
    Feed(lcm, node, clock, events_, 0, events_.size() / 2);
    ASSERT_TRUE(node.SaveCheckpoint());
    flight1_hash = node.map_hash();
    flight1_sequences = node.sequences();
  }
  ASSERT_NE(flight1_hash, empty_hash);
  // The same run resumes it.
  {
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode node(lcm, flight1, clock);
    EXPECT_TRUE(node.resumed());
    EXPECT_EQ(node.map_hash(), flight1_hash);
  }
  // Another run does not, and keeps the file aside.
  MapperConfig flight2 = flight1;
  flight2.run_id = "flight-2";
  {
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode node(lcm, flight2, clock);
    EXPECT_FALSE(node.resumed());
    EXPECT_EQ(node.map_hash(), empty_hash);
    EXPECT_TRUE(node.sequences().empty());
    EXPECT_FALSE(Exists(path));
    ASSERT_TRUE(Exists(path + ".run-flight-1"));
    EXPECT_EQ(ReadMapFileInfo(path + ".run-flight-1").run_id, "flight-1");
    Feed(lcm, node, clock, events_, 0, 40);
    ASSERT_TRUE(node.SaveCheckpoint());
    EXPECT_EQ(ReadMapFileInfo(path).run_id, "flight-2");
    EXPECT_EQ(ReadMapFileInfo(path + ".run-flight-1").run_id, "flight-1") << "overwritten";
  }
  // A second checkpoint of flight-1 set aside does not replace the first one.
  ASSERT_EQ(std::rename((path + ".run-flight-1").c_str(), path.c_str()), 0);
  {
    std::ofstream(path + ".run-flight-1") << "an earlier file";
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode node(lcm, flight2, clock);
    EXPECT_FALSE(node.resumed());
    EXPECT_EQ(ReadAll(path + ".run-flight-1"), "an earlier file");
    EXPECT_EQ(ReadMapFileInfo(path + ".run-flight-1.2").run_id, "flight-1");
  }
  // No run id: a fresh one, which resumes nothing.
  ASSERT_EQ(std::rename((path + ".run-flight-1.2").c_str(), path.c_str()), 0);
  MapperConfig unnamed = flight1;
  unnamed.run_id = "";
  {
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode node(lcm, unnamed, clock);
    EXPECT_FALSE(node.resumed());
    EXPECT_FALSE(node.run_id().empty());
    EXPECT_NE(node.run_id(), "flight-1");
    EXPECT_TRUE(Exists(path + ".run-flight-1.2"));
  }
  // Asked explicitly (resume = any), another run's checkpoint is resumed, and the rest of the
  // stream then gives the uninterrupted map.
  ASSERT_EQ(std::rename((path + ".run-flight-1.2").c_str(), path.c_str()), 0);
  MapperConfig any = flight2;
  any.run_id = "flight-3";
  any.resume = "any";
  {
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode node(lcm, any, clock);
    EXPECT_TRUE(node.resumed());
    EXPECT_EQ(node.map_hash(), flight1_hash);
    EXPECT_EQ(node.sequences(), flight1_sequences);
    Feed(lcm, node, clock, events_);
    uint64_t uninterrupted = 0;
    {
      lcm::LCM lcm2("memq://");
      SimClock clock2;
      MapperNode fresh(lcm2, config_, clock2);
      Feed(lcm2, fresh, clock2, events_);
      uninterrupted = fresh.map_hash();
    }
    EXPECT_EQ(node.map_hash(), uninterrupted);
    ASSERT_TRUE(node.SaveCheckpoint());
    EXPECT_EQ(ReadMapFileInfo(path).run_id, "flight-3") << "the checkpoint is now this run's";
  }
  for (const std::string& p : {path, path + ".run-flight-1", path + ".run-flight-1.2"}) {
    std::remove(p.c_str());
  }
}

// Every message the mapper publishes carries its epoch, and two mappers in one process have
// different epochs (and so does each one's heartbeat).
TEST_F(MapperNodeTest, StampsItsEpochAndTwoNodesDiffer) {
  lcm::LCM lcm("memq://");
  SimClock clock;
  MapperNode a(lcm, config_, clock);
  MapperNode b(lcm, config_, clock);
  EXPECT_NE(a.epoch(), 0);
  EXPECT_NE(b.epoch(), 0);
  EXPECT_NE(a.epoch(), b.epoch());
  std::vector<int64_t> epochs;
  int statuses = 0;
  std::set<int64_t> heartbeat_epochs;
  GuardedSubscriptions subs(lcm);
  subs.Add<map3d_chunk_t>(
      "MAP3D", [&](const std::string&, const map3d_chunk_t& m) { epochs.push_back(m.epoch); },
      nullptr);
  subs.Add<map3d_delta_t>(
      "MAP3D_DELTA", [&](const std::string&, const map3d_delta_t& m) { epochs.push_back(m.epoch); },
      nullptr);
  subs.Add<map_status_t>(
      "MAP_STATUS",
      [&](const std::string&, const map_status_t& m) {
        epochs.push_back(m.epoch);
        ++statuses;
      },
      nullptr);
  subs.Add<heartbeat_t>(
      "HEARTBEAT_MAPPER",
      [&](const std::string&, const heartbeat_t& m) { heartbeat_epochs.insert(m.epoch); }, nullptr);
  Feed(lcm, a, clock, events_, 0, 60);  // both nodes hear the stream
  for (MapperNode* node : {&a, &b}) {
    epochs.clear();
    statuses = 0;
    node->PublishSnapshot();
    while (lcm.handleTimeout(0) > 0) {
    }
    Feed(lcm, *node, clock, events_, 60, 80);
    node->PublishDelta();
    node->PublishStatus();
    while (lcm.handleTimeout(0) > 0) {
    }
    ASSERT_GE(epochs.size(), 3u) << "snapshot chunks, a delta (or a snapshot) and a status";
    EXPECT_EQ(statuses, 1);
    for (int64_t e : epochs) EXPECT_EQ(e, node->epoch());
  }
  EXPECT_EQ(heartbeat_epochs.size(), 2u);
  EXPECT_EQ(heartbeat_epochs.count(0), 0u);
}

TEST_F(MapperNodeTest, StatusReportsSkipsAndEntropy) {
  lcm::LCM lcm("memq://");
  SimClock clock;
  MapperNode node(lcm, config_, clock);
  std::vector<map_status_t> statuses;
  GuardedSubscriptions subs(lcm);
  subs.Add<map_status_t>(
      "MAP_STATUS", [&](const std::string&, const map_status_t& m) { statuses.push_back(m); },
      nullptr);
  Feed(lcm, node, clock, events_);
  node.PublishStatus();
  lcm.handleTimeout(0);
  ASSERT_EQ(statuses.size(), 1u);
  EXPECT_EQ(statuses[0].scans_applied, 60);
  EXPECT_EQ(statuses[0].map_seq, node.map_seq());
  EXPECT_DOUBLE_EQ(statuses[0].map_entropy_nats, node.entropy_nats());
  EXPECT_TRUE(statuses[0].applied_every_message);
  EXPECT_EQ(statuses[0].ray_decimation, 1.0);
}

// ---- Decisions (docs/design.md §3.6) ----

/// Gathers what a node publishes on MAP_DECISIONS.
struct DecisionsHeard {
  explicit DecisionsHeard(lcm::LCM& lcm) : subs(lcm) {
    subs.Add<map_decisions_t>(
        "MAP_DECISIONS",
        [this](const std::string&, const map_decisions_t& m) {
          std::string why;
          EXPECT_TRUE(history.Add(m, &why)) << why;
          messages.push_back(m);
        },
        nullptr);
  }
  GuardedSubscriptions subs;
  DecisionHistory history;
  std::vector<map_decisions_t> messages;
};

/// A loaded host: the node takes one scan off its queue after every `every`-th message only, so
/// its backlog grows (rays thinned, the queue limit drops scans), and the scans whose index is in
/// `lost` never reach it (a full socket buffer), though the log has them.
void FeedOverloaded(lcm::LCM& lcm, MapperNode& node, SimClock& clock,
                    const std::vector<StreamEvent>& events, int every,
                    const std::set<size_t>& lost) {
  for (size_t i = 0; i < events.size(); ++i) {
    const StreamEvent& e = events[i];
    if (e.utime > clock.NowUtime()) clock.SetUtime(e.utime);
    if (lost.count(i) == 0) {
      if (e.kind == StreamEvent::Kind::kPose) lcm.publish("POSE_VICON", &e.pose);
      if (e.kind == StreamEvent::Kind::kDepth) lcm.publish("DEPTH_XTION", &e.depth);
      if (e.kind == StreamEvent::Kind::kScan) lcm.publish("SCAN_HOKUYO", &e.scan);
    }
    while (lcm.handleTimeout(0) > 0) {
    }
    if (i % every == 0) node.ProcessPending(1);
    node.PublishDue();
    while (lcm.handleTimeout(0) > 0) {
    }
  }
  node.ApplyRemaining();
  node.PublishDecisions();
  while (lcm.handleTimeout(0) > 0) {
  }
}

/// A replay of every event into a fresh node that follows `decisions` (none: its own).
uint64_t ReplayHash(const MapperConfig& config, const std::vector<StreamEvent>& events,
                    std::vector<map_decision_t> decisions, size_t* left = nullptr) {
  lcm::LCM lcm("memq://");
  SimClock clock;
  MapperNode node(lcm, config, clock);
  if (!decisions.empty()) node.FollowDecisions(std::move(decisions));
  Feed(lcm, node, clock, events);
  if (left != nullptr) *left = node.decisions_to_follow().size();
  return node.map_hash();
}

// A mapper that falls behind thins rays, drops scans at its queue limit and misses datagrams:
// its map is not that of a mapper that kept up. Its decisions (published on MAP_DECISIONS) let a
// replay of the whole stream rebuild its map bit for bit; without them the replay differs; a
// decision whose scan the log lacks is left unfollowed.
TEST_F(MapperNodeTest, AReplayFollowingTheDecisionsHoldsTheMapOfAMapperThatFellBehind) {
  MapperConfig loaded = config_;
  loaded.max_backlog_s = 0.35;
  loaded.order_wait_s = 0.1;
  loaded.max_queue = 8;
  std::set<size_t> lost;
  for (size_t i = 0; i < events_.size(); ++i) {
    if (events_[i].kind != StreamEvent::Kind::kPose && i % 7 == 3) lost.insert(i);
    if (events_[i].kind == StreamEvent::Kind::kPose && i % 11 == 5) lost.insert(i);
  }
  lcm::LCM lcm("memq://");
  SimClock clock;
  MapperNode live(lcm, loaded, clock);
  DecisionsHeard heard(lcm);
  FeedOverloaded(lcm, live, clock, events_, 10, lost);
  EXPECT_FALSE(live.applied_every_message());
  EXPECT_GT(live.skipped().count("overload"), 0) << "the queue limit dropped scans";
  std::string why;
  const std::vector<map_decision_t> decisions = heard.history.MapOf(live.epoch(), &why);
  ASSERT_EQ(static_cast<int64_t>(decisions.size()), live.decisions_taken()) << why;
  int thinned = 0, dropped = 0;
  for (const map_decision_t& d : decisions) {
    thinned += d.action == map_decision_t::ACTION_APPLIED && d.ray_stride > 1 ? 1 : 0;
    dropped += d.action == map_decision_t::ACTION_SKIPPED && d.reason == "overload" ? 1 : 0;
  }
  EXPECT_GT(thinned, 0) << "rays were thinned";
  EXPECT_EQ(dropped, live.skipped().count("overload"));
  EXPECT_GT(heard.messages.size(), 1u) << "published as taken, not only at the end";

  size_t left = 0;
  EXPECT_EQ(ReplayHash(loaded, events_, decisions, &left), live.map_hash());
  EXPECT_EQ(left, 0u);
  EXPECT_NE(ReplayHash(loaded, events_, {}), live.map_hash()) << "the decisions mattered";
  // The log without one scan the live mapper applied: that decision cannot be followed.
  std::vector<StreamEvent> short_log;
  bool dropped_one = false;
  for (size_t i = 0; i < events_.size(); ++i) {
    const StreamEvent& e = events_[i];
    if (!dropped_one && e.kind == StreamEvent::Kind::kScan && lost.count(i) == 0) {
      dropped_one = true;
      continue;
    }
    short_log.push_back(e);
  }
  ReplayHash(loaded, short_log, decisions, &left);
  EXPECT_GT(left, 0u) << "the missing scan's decision (and those after it) are left";
}

// decisions_log holds the decisions and every scan applied, as received: the map can be rebuilt
// from it alone, even where the run's log missed a scan the mapper had.
TEST_F(MapperNodeTest, TheDecisionsLogAloneRebuildsTheMap) {
  MapperConfig loaded = config_;
  loaded.max_backlog_s = 0.35;
  loaded.order_wait_s = 0.1;
  loaded.max_queue = 8;
  loaded.decisions_log = TempPath("decisions.lcmlog");
  uint64_t live_hash = 0;
  int64_t live_epoch = 0;
  {
    lcm::LCM lcm("memq://");
    SimClock clock;
    MapperNode live(lcm, loaded, clock);
    FeedOverloaded(lcm, live, clock, events_, 10, {});
    live_hash = live.map_hash();
    live_epoch = live.epoch();
  }
  DecisionHistory history;
  std::vector<std::pair<std::string, std::vector<uint8_t>>> scans;
  {
    LogTail log(loaded.decisions_log);
    while (const std::optional<LoggedEvent> e = log.Next()) {
      if (e->channel == "MAP_DECISIONS") {
        map_decisions_t m;
        std::string why;
        ASSERT_TRUE(GuardedDecode(e->data.data(), e->data.size(), &m, &why)) << why;
        ASSERT_TRUE(history.Add(m, &why)) << why;
      } else {
        scans.emplace_back(e->channel, e->data);
      }
    }
  }
  std::string why;
  std::vector<map_decision_t> decisions = history.MapOf(live_epoch, &why);
  ASSERT_FALSE(decisions.empty()) << why;
  size_t applied = 0;
  for (const map_decision_t& d : decisions) {
    applied += d.action == map_decision_t::ACTION_APPLIED ? 1 : 0;
  }
  EXPECT_EQ(scans.size(), applied) << "exactly the scans applied, nothing else";
  lcm::LCM lcm("memq://");
  SimClock clock;
  MapperConfig replay = config_;
  MapperNode node(lcm, replay, clock);
  node.FollowDecisions(std::move(decisions));
  for (const auto& [channel, bytes] : scans)
    node.HandleRecorded(channel, bytes.data(), bytes.size());
  node.ApplyRemaining();
  EXPECT_TRUE(node.decisions_to_follow().empty());
  EXPECT_EQ(node.map_hash(), live_hash);
  std::remove(loaded.decisions_log.c_str());
}

// A respawned mapper resumes its checkpoint: its decisions name the history the checkpoint holds
// (the first N decisions of the life before), so the map of the last life is that history and
// its own decisions, whatever the first life did after its checkpoint.
TEST_F(MapperNodeTest, DecisionsContinueAcrossACheckpointResume) {
  const std::string path = TempPath("decisions.kmap");
  MapperConfig config = config_;
  config.checkpoint_path = path;
  config.run_id = "decisions-run";
  config.max_backlog_s = 0.35;
  config.order_wait_s = 0.1;
  config.max_queue = 8;
  lcm::LCM lcm("memq://");
  DecisionsHeard heard(lcm);
  SimClock clock;
  int64_t first_epoch = 0, checkpointed = 0;
  {
    MapperNode first(lcm, config, clock);
    first_epoch = first.epoch();
    const std::vector<StreamEvent> half(events_.begin(), events_.begin() + events_.size() / 2);
    FeedOverloaded(lcm, first, clock, half, 10, {});
    ASSERT_TRUE(first.SaveCheckpoint());
    checkpointed = first.decisions_taken();
    // Work after the checkpoint, lost with the process (killed with -9).
    Feed(lcm, first, clock,
         std::vector<StreamEvent>(events_.begin() + events_.size() / 2,
                                  events_.begin() + events_.size() / 2 + 60));
    first.PublishDecisions();
    while (lcm.handleTimeout(0) > 0) {
    }
    EXPECT_GT(first.decisions_taken(), checkpointed);
  }
  MapperNode second(lcm, config, clock);
  ASSERT_TRUE(second.resumed());
  ASSERT_EQ(second.resumed_lives().size(), 1u);
  EXPECT_EQ(second.resumed_lives()[0].epoch, first_epoch);
  EXPECT_EQ(second.resumed_lives()[0].last_seq, checkpointed);
  FeedOverloaded(lcm, second, clock, events_, 10, {});  // the whole stream: the first half skipped
  std::string why;
  const std::vector<map_decision_t> decisions = heard.history.MapOf(second.epoch(), &why);
  ASSERT_EQ(static_cast<int64_t>(decisions.size()), checkpointed + second.decisions_taken()) << why;
  EXPECT_EQ(heard.history.lives(), (std::vector<int64_t>{first_epoch, second.epoch()}));
  EXPECT_EQ(ReplayHash(config_, events_, decisions), second.map_hash());
  // The first life's decisions after its checkpoint are not in the second's map.
  EXPECT_NE(ReplayHash(config_, events_, heard.history.MapOf(first_epoch, &why)),
            second.map_hash());
  std::remove(path.c_str());
}

TEST(DecisionHistory, GathersMessagesInAnyOrderAndNamesWhatIsMissing) {
  const auto decision = [](int64_t seq) {
    map_decision_t d{};
    d.channel = "SCAN_HOKUYO";
    d.epoch = 7;
    d.seq = seq;
    d.ray_stride = 1;
    d.orientation_wxyz[0] = 1;
    return d;
  };
  const auto message = [&](int64_t epoch, int64_t first, int count,
                           std::vector<std::pair<int64_t, int64_t>> lives) {
    map_decisions_t m{};
    m.epoch = epoch;
    m.first_index = first;
    for (int i = 0; i < count; ++i) m.decisions.push_back(decision(100 * epoch + first + i));
    m.num_decisions = count;
    for (const auto& [e, n] : lives) {
      m.life_epochs.push_back(e);
      m.life_decisions.push_back(n);
    }
    m.num_lives = static_cast<int32_t>(lives.size());
    return m;
  };
  DecisionHistory h;
  std::string why;
  ASSERT_TRUE(h.Add(message(1, 3, 3, {}), &why)) << why;  // out of order
  ASSERT_TRUE(h.Add(message(1, 0, 3, {}), &why)) << why;
  ASSERT_TRUE(h.Add(message(1, 0, 3, {}), &why)) << "a message heard twice is harmless";
  ASSERT_TRUE(h.Add(message(2, 0, 2, {{1, 4}}), &why)) << why;
  std::vector<map_decision_t> map = h.MapOf(2, &why);
  ASSERT_EQ(map.size(), 6u) << why;
  EXPECT_EQ(map[0].seq, 100);
  EXPECT_EQ(map[3].seq, 103) << "the first life's first 4 decisions";
  EXPECT_EQ(map[4].seq, 200);
  EXPECT_EQ(h.lives(), (std::vector<int64_t>{1, 2}));
  // Contradictions are refused and change nothing.
  map_decisions_t other = message(1, 2, 1, {});
  other.decisions[0].ray_stride = 4;
  EXPECT_FALSE(h.Add(other, &why));
  EXPECT_NE(why.find("decision 2 heard twice, unlike"), std::string::npos) << why;
  EXPECT_FALSE(h.Add(message(2, 2, 1, {{1, 5}}), &why));
  EXPECT_NE(why.find("different resumed lives"), std::string::npos) << why;
  map_decisions_t bad = message(3, 0, 1, {});
  bad.num_decisions = 5;
  EXPECT_FALSE(h.Add(bad, &why));
  // A gap in the last life, or a resumed life never heard, is named.
  ASSERT_TRUE(h.Add(message(2, 4, 1, {{1, 4}}), &why));
  EXPECT_TRUE(h.MapOf(2, &why).empty());
  EXPECT_NE(why.find("decision 2 of mapper epoch 2 is missing"), std::string::npos) << why;
  ASSERT_TRUE(h.Add(message(4, 0, 1, {{9, 2}}), &why));
  EXPECT_TRUE(h.MapOf(4, &why).empty());
  EXPECT_NE(why.find("no decision of resumed mapper epoch 9"), std::string::npos) << why;
}

// A chunk whose block index times its edge overflows int (2^28 x 8) is refused, not applied:
// the replica computed its cells in int before (undefined behaviour, caught by UBSan in
// tests/fuzz/lcm_fuzz.cc); the codec now checks the index range first.
// instruction_set takes the name of any instruction set this CPU runs; any other is refused with
// the file, the key and the list of those the CPU runs.
TEST(MapperConfig, InstructionSetIsOneThisCpuRuns) {
  for (const std::string& isa : ScanIntegrator::SupportedInstructionSets()) {
    const ConfigNode node = ConfigNode::FromString("instruction_set: " + isa + "\n", "mapper.yaml");
    EXPECT_EQ(LoadMapperConfig(node).instruction_set, isa);
  }
  try {
    (void)LoadMapperConfig(ConfigNode::FromString("instruction_set: sse9\n", "mapper.yaml"));
    ADD_FAILURE() << "sse9 accepted";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    for (const std::string& part : {std::string("mapper.yaml"), std::string("instruction_set"),
                                    ScanIntegrator::SupportedInstructionSets().back()}) {
      EXPECT_NE(what.find(part), std::string::npos) << what;
    }
  }
}

TEST(MapReplica, BlockIndexOutsideTheCellRangeIsRefused) {
  MapReplica replica(Eigen::Vector3d::Zero(), 0.1, Eigen::Vector3i(16, 16, 16), 0.5);
  map3d_chunk_t chunk{};
  chunk.num_chunks = 1;
  chunk.resolution_m = 0.1;
  chunk.block_edge = 8;
  chunk.num_blocks = 1;
  chunk.block_index.push_back({1 << 28, 0, 0});
  chunk.encoding = map3d_chunk_t::ENCODING_FLOAT32;
  chunk.data.assign(512 * 4, 0);
  chunk.data_size = 512 * 4;
  std::string error;
  EXPECT_FALSE(replica.Apply(chunk, &error));
  EXPECT_NE(error.find("outside the cell range"), std::string::npos) << error;
  EXPECT_FALSE(replica.current());
}

}  // namespace
}  // namespace kestrel
