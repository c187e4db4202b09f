#!/usr/bin/env python3
"""Checks a chaos flight's LCM log (tests/system/chaos_test.sh, docs/design.md §7.11): the vehicle
stayed inside the geofence and never touched anything, came home and landed; for each process
killed, how long it was down and what the vehicle did meanwhile (the controller's mode, the
height lost, the speed); and each process's drops by reason from its last heartbeat.

Usage: chaos_check.py LOG KILLS --fence-min X,Y,Z --fence-max X,Y,Z [--burst BURST]
  KILLS: lines "<heartbeat channel of the process> <wall time of the kill, us>".
  BURST: kestrel-fault malformed's output ("<CHANNEL> (<type>): N sent, ..."): each process's
  last heartbeat must count exactly the malformed messages sent on the channels it reads.
Needs Kestrel's Python message types on PYTHONPATH (<build>/lcmtypes/python) and read_log.py
(tools/python) beside them or on the path. Exits 1 when a check fails.
"""
import argparse
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools",
                                "python"))
import kestrel  # noqa: E402
from read_log import decoders, events  # noqa: E402

MODES = {0: "IDLE", 1: "TAKEOFF", 2: "TRACK", 3: "HOLD", 4: "LAND", 5: "ESTOP"}

# What each process of the chaos sheet reads, by the heartbeat value that counts what it refuses.
READS = {
    "HEARTBEAT_SIM": {"dropped.malformed": ["MOTOR_COMMAND"]},
    "HEARTBEAT_STANDIN_DEPTH": {"dropped.malformed": ["DEV_DEPTH_XTION"]},
    "HEARTBEAT_STANDIN_SCAN": {"dropped.malformed": ["DEV_SCAN_HOKUYO"]},
    "HEARTBEAT_MAPPER": {"dropped.malformed": ["DEPTH_XTION", "SCAN_HOKUYO"],
                         "dropped.malformed_pose": ["POSE_VICON"]},
    "HEARTBEAT_CONTROLLER": {"dropped.malformed": ["POSE_VICON", "IMU", "TRAJECTORY", "COMMAND"]},
    "HEARTBEAT_EXPLORER": {"dropped.malformed": ["MAP3D", "MAP3D_DELTA", "POSE_VICON",
                                                 "CONTROLLER_STATUS"]},
}


def vector(text):
    return [float(v) for v in text.strip("[]").split(",")]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("log")
    parser.add_argument("kills")
    parser.add_argument("--fence-min", type=vector, required=True)
    parser.add_argument("--fence-max", type=vector, required=True)
    parser.add_argument("--burst")
    args = parser.parse_args()
    table = decoders()
    truth, status, beats, explorer, motors = [], [], {}, [], []
    undecodable = 0
    for utime, channel, data in events(args.log):
        t = table.get(data[:8])
        if t is None:
            continue
        try:
            m = t.decode(data)
        except Exception:  # the malformed burst: a kestrel fingerprint over bad bytes
            undecodable += 1
            continue
        if channel == "SIM_TRUTH" and t is kestrel.sim_truth_t:
            truth.append((utime, m))
        elif channel == "CONTROLLER_STATUS" and t is kestrel.controller_status_t:
            status.append((utime, m))
        elif channel.startswith("HEARTBEAT_") and t is kestrel.heartbeat_t:
            beats.setdefault(channel, []).append((utime, m))
        elif channel == "EXPLORATION_STATUS" and t is kestrel.exploration_status_t:
            explorer.append((utime, m))
        elif channel == "MOTOR_COMMAND" and t is kestrel.motor_command_t:
            motors.append((utime, m.epoch))
    failures = []
    print(f"log: {len(truth)} truths, {len(status)} controller statuses, "
          f"{sum(len(b) for b in beats.values())} heartbeats, {undecodable} malformed messages")
    if not truth or not status:
        print("FAIL: no SIM_TRUTH or CONTROLLER_STATUS in the log")
        return 1

    # Geofence, contacts, home and landing.
    lo = [min(m.position_m[a] for _, m in truth) for a in range(3)]
    hi = [max(m.position_m[a] for _, m in truth) for a in range(3)]
    print("flown box: [" + ", ".join(f"{v:.2f}" for v in lo) + "] .. [" +
          ", ".join(f"{v:.2f}" for v in hi) + "]")
    if any(lo[a] < args.fence_min[a] or hi[a] > args.fence_max[a] for a in range(3)):
        failures.append("the vehicle left the geofence")
    collisions = max(m.collision_count for _, m in truth)
    print(f"collisions: {collisions}")
    if collisions != 0:
        failures.append(f"{collisions} collisions")
    start, end = truth[0][1].position_m, truth[-1][1].position_m
    home = math.hypot(end[0] - start[0], end[1] - start[1])
    print(f"end: {home:.2f} m from the start, {end[2] - start[2]:.2f} m above it, "
          f"controller {MODES.get(status[-1][1].mode, '?')}")
    if home > 0.5 or end[2] - start[2] > 0.15 or status[-1][1].mode != 0:
        failures.append("the vehicle did not come home and land (IDLE)")

    # Each kill: down time (until the process's first heartbeat of a new epoch) and the vehicle
    # meanwhile.
    with open(args.kills) as f:
        kills = [(line.split()[0], int(line.split()[1])) for line in f if line.strip()]
    for process, at in kills:
        lives = beats.get(process, [])
        before = [m.epoch for u, m in lives if u <= at]
        after = [(u, m) for u, m in lives if u > at and (not before or m.epoch != before[-1])]
        if not before or not after:
            failures.append(f"{process}: no heartbeat before the kill or none of a new life after")
            continue
        back = after[0][0]
        window = [m for u, m in truth if at <= u <= back + 1_000_000]
        z_before = [m.position_m[2] for u, m in truth if at - 1_000_000 <= u <= at]
        height_lost = (max(z_before) - min(m.position_m[2] for m in window)) if window and z_before else 0
        speed = max((math.sqrt(sum(v * v for v in m.velocity_mps)) for m in window), default=0)
        modes = sorted({MODES.get(m.mode, "?") for u, m in status if at <= u <= back + 1_000_000})
        print(f"kill -9 {process}: back after {(back - at) * 1e-6:.2f} s; meanwhile (+1 s) "
              f"controller modes {modes}, height lost {height_lost:.2f} m, top speed {speed:.2f} m/s")
        if process in ("HEARTBEAT_EXPLORER", "HEARTBEAT_CONTROLLER") and \
                any(m in ("LAND", "ESTOP", "IDLE") for m in modes):
            failures.append(f"{process} down: the controller went to {modes}")
        if process == "HEARTBEAT_CONTROLLER":
            # The new life's first status (its epoch): under load the logger may stamp the old
            # controller's last statuses after the kill.
            old_lives = {m.epoch for u, m in status if u <= at}
            new_modes = [MODES.get(m.mode) for u, m in status
                         if u > at and m.epoch not in old_lives][:1]
            print(f"  the respawned controller's first mode: {new_modes}")
            # The rotors' own view of the gap: the old controller's last motor command to the new
            # one's first (docs/design.md §2.5: the ESC hold must outlast it).
            old_epochs = {e for u, e in motors if u <= at}
            last_old = max((u for u, e in motors if e in old_epochs), default=None)
            first_new = min((u for u, e in motors if u > at and e not in old_epochs), default=None)
            if last_old is not None and first_new is not None:
                print(f"  motor commands: none for {(first_new - last_old) * 1e-6:.2f} s")
            if new_modes != ["HOLD"]:
                failures.append(f"the respawned controller started in {new_modes}, not HOLD")
            if height_lost > 0.2:
                failures.append(f"{height_lost:.2f} m lost while the controller was down")

    # Drops by reason, from each process's last heartbeat (its current life).
    for process in sorted(beats):
        _, last = beats[process][-1]
        drops = {v.name: v.value for v in last.values if v.name.startswith("dropped.")}
        print(f"{process}: " + (", ".join(f"{k}={v:g}" for k, v in sorted(drops.items()))
                                or "no drop counters"))
        if process.startswith("HEARTBEAT_STANDIN_"):
            frames = next((v.value for v in last.values if v.name == "device_frames"), 0)
            lost = drops.get("dropped.link_loss", 0)
            if frames < 100 or not 0.05 <= lost / frames <= 0.15:
                failures.append(f"{process}: {lost:g} of {frames:g} frames lost, not about 10%")
    if args.burst:
        sent = {}
        with open(args.burst) as f:
            for line in f:
                words = line.split()
                if len(words) >= 4 and words[1].startswith("(") and words[3].startswith("sent"):
                    sent[words[0]] = int(words[2])
        print(f"burst: {sum(sent.values())} malformed messages on {len(sent)} channels")
        for process, reads in READS.items():
            _, last = beats.get(process, [(0, None)])[-1]
            values = {} if last is None else {v.name: v.value for v in last.values}
            for name, channels in reads.items():
                expected = sum(sent.get(c, 0) for c in channels)
                got = values.get(name, 0)
                if got != expected:
                    failures.append(f"{process}: {name} = {got:g}, but {expected} malformed "
                                    f"messages were sent on {', '.join(channels)}")

    for f in failures:
        print(f"FAIL: {f}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
