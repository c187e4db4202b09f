#!/usr/bin/env python3
"""LCM traffic in a log (lcm-logger's format): bytes per second of every channel (channel name and
payload; UDP/IP headers not counted), mean over the log and the largest over any 1 s window (by
the log's receive stamps), then per vehicle (channels with a V<k>_ prefix) and for the map the
mapper sends the explorers and the viewer (MAP3D snapshots and MAP3D_DELTA).

Usage: log_traffic.py LOG [--seconds S]   (S: the duration to divide by; default: the log's span)
"""
import argparse
import collections
import re
import struct
import sys


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("log")
    parser.add_argument("--seconds", type=float, default=0.0)
    args = parser.parse_args()
    data = open(args.log, "rb").read()
    pos = 0
    total = collections.Counter()
    per_second = collections.defaultdict(collections.Counter)  # channel -> second -> bytes
    first = last = None
    while pos + 28 <= len(data):
        sync, _, utime, clen, dlen = struct.unpack_from(">IqqII", data, pos)
        if sync != 0xEDA1DA01:
            sys.exit("log_traffic: bad sync word at byte %d" % pos)
        channel = data[pos + 28:pos + 28 + clen].decode()
        first = utime if first is None else first
        last = utime
        total[channel] += clen + dlen
        per_second[channel][(utime - first) // 1000000] += clen + dlen
        pos += 28 + clen + dlen
    if first is None:
        sys.exit("log_traffic: empty log")
    seconds = args.seconds if args.seconds > 0 else max(1e-6, (last - first) / 1e6)
    print("%-28s %12s %14s" % ("channel", "mean bytes/s", "peak 1 s bytes"))
    for channel in sorted(total):
        print("%-28s %12.0f %14d" % (channel, total[channel] / seconds,
                                       max(per_second[channel].values())))
    groups = collections.defaultdict(set)
    for channel in total:
        m = re.match(r"(V\d+_)", channel)
        groups[m.group(1) if m else "shared"].add(channel)
    groups["map (MAP3D, MAP3D_DELTA)"] = {c for c in total if c in ("MAP3D", "MAP3D_DELTA")}
    print()
    for name in sorted(groups):
        chans = groups[name]
        mean = sum(total[c] for c in chans) / seconds
        window = collections.Counter()
        for c in chans:
            window.update(per_second[c])
        peak = max(window.values()) if window else 0
        print("%-26s mean %10.0f bytes/s (%.3f MB/s), peak %.3f MB in 1 s" %
              (name, mean, mean / 1e6, peak / 1e6))
    print("\nover %.1f s" % seconds)


if __name__ == "__main__":
    main()
