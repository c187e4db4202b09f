#!/usr/bin/env python3
"""Prints the median, 99th percentile and maximum of each histogram in a loop-timing CSV
(kestrel-controller's loop_timing_path: bin_start_us, then one count column per histogram, 10 us
bins; docs/design.md §2.6). Each figure is the upper edge of its bin.

Usage: loop_timing.py CSV
"""
import csv
import sys


def main():
    rows = list(csv.DictReader(open(sys.argv[1])))
    if not rows:
        print("no ticks recorded")
        return 1
    width = int(rows[1]["bin_start_us"]) - int(rows[0]["bin_start_us"]) if len(rows) > 1 else 10
    for name in [k for k in rows[0] if k != "bin_start_us"]:
        counts = [(int(r["bin_start_us"]), int(r[name])) for r in rows]
        total = sum(c for _, c in counts)
        if total == 0:
            continue

        def quantile(q):
            seen = 0
            for start, c in counts:
                seen += c
                if seen >= q * total:
                    return start + width
            return counts[-1][0] + width

        last = max(start for start, c in counts if c)
        print("%-9s n %6d  p50 %5d us  p99 %5d us  max < %5d us"
              % (name, total, quantile(0.5), quantile(0.99), last + width))
    return 0


if __name__ == "__main__":
    sys.exit(main())
