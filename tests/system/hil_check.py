#!/usr/bin/env python3
"""Measures a scripted flight (take-off, hover, a go-to, landing) from its LCM log
(tests/system/hil_test.sh, docs/design.md §7.12) and prints one line of figures:

  hover_rms_m hover_max_m track_rms_m track_max_m landed collisions motor_commands imu_samples

The error is the simulator's true position (SIM_TRUTH) against the controller's set point at the
same moment (CONTROLLER_STATUS: estimated position minus position error), in the hover (from
HOVER_SETTLE s after the first HOLD to the go-to's TRAJECTORY) and along the go-to (its start to
its end plus 1 s). landed: the controller ended IDLE after LAND with the vehicle on the floor.

Usage: hil_check.py LOG [--motor-channel MOTOR_COMMAND] [--imu-channel IMU]
                        [--max-hover-rms M] [--max-track-rms M] [--hover-settle S]
Exits 1 when a bound is exceeded, the flight did not land, or it touched anything.
Needs Kestrel's Python message types on PYTHONPATH (<build>/lcmtypes/python).
"""
import argparse
import bisect
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools",
                                "python"))
import kestrel  # noqa: E402,F401
from read_log import decoders, events  # noqa: E402

IDLE, HOLD, LAND = 0, 3, 4


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("log")
    parser.add_argument("--motor-channel", default="MOTOR_COMMAND")
    parser.add_argument("--imu-channel", default="IMU")
    parser.add_argument("--max-hover-rms", type=float, default=float("inf"))
    parser.add_argument("--max-track-rms", type=float, default=float("inf"))
    parser.add_argument("--hover-settle", type=float, default=2.0)
    args = parser.parse_args()
    table = decoders()

    def decode(data):
        return table[data[:8]].decode(data)

    truth_t, truth_p, statuses, trajectories = [], [], [], []
    motor_commands = imu_samples = collisions = 0
    for _, channel, data in events(args.log):
        if channel == "SIM_TRUTH":
            m = decode(data)
            truth_t.append(m.utime)
            truth_p.append(list(m.position_m))
            collisions = max(collisions, m.collision_count)
        elif channel == "CONTROLLER_STATUS":
            statuses.append(decode(data))
        elif channel == "TRAJECTORY":
            trajectories.append(decode(data))
        elif channel == args.motor_channel:
            motor_commands += 1
        elif channel == args.imu_channel:
            imu_samples += 1
    if not truth_t or not statuses or not trajectories:
        print("FAIL: the log lacks SIM_TRUTH, CONTROLLER_STATUS or the go-to TRAJECTORY")
        return 1
    goto = trajectories[-1]
    goto_start = goto.start_utime
    goto_end = goto_start + int(sum(goto.durations_s) * 1e6)
    first_hold = next((s.utime for s in statuses if s.mode == HOLD), None)
    if first_hold is None:
        print("FAIL: the controller never held after its take-off")
        return 1

    def errors(start, end):
        out = []
        for s in statuses:
            if not start <= s.utime <= end:
                continue
            i = bisect.bisect_left(truth_t, s.utime)
            if i == len(truth_t):
                continue
            set_point = [s.position_m[k] - s.e_x_m[k] for k in range(3)]
            out.append(math.dist(truth_p[i], set_point))
        return out

    hover = errors(first_hold + int(args.hover_settle * 1e6), goto_start)
    track = errors(goto_start, goto_end + 1000000)
    if len(hover) < 10 or len(track) < 10:
        print("FAIL: too few statuses in the hover (%d) or the go-to (%d)" % (len(hover), len(track)))
        return 1

    def rms(values):
        return math.sqrt(sum(v * v for v in values) / len(values))

    modes = [s.mode for s in statuses]
    landed = LAND in modes and modes[-1] == IDLE and truth_p[-1][2] < 0.2
    print("hover_rms_m %.4f hover_max_m %.4f track_rms_m %.4f track_max_m %.4f landed %d "
          "collisions %d motor_commands %d imu_samples %d"
          % (rms(hover), max(hover), rms(track), max(track), landed, collisions, motor_commands,
             imu_samples))
    failed = []
    if rms(hover) > args.max_hover_rms:
        failed.append("hover RMS error %.4f m > %.4f m" % (rms(hover), args.max_hover_rms))
    if rms(track) > args.max_track_rms:
        failed.append("go-to RMS error %.4f m > %.4f m" % (rms(track), args.max_track_rms))
    if not landed:
        failed.append("did not land (modes end %s, height %.2f m)" % (modes[-3:], truth_p[-1][2]))
    if collisions:
        failed.append("%d collisions" % collisions)
    for f in failed:
        print("FAIL: " + f)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
