#!/usr/bin/env python3
"""Prints the messages of an LCM log (lcm-logger, kestrel-mission --log) decoded with Kestrel's
Python message types (lcm-gen --python, package `kestrel`), one line per event:

    <seconds since the first event> <channel> <type> field=value ...

Usage: read_log.py LOG [--channel REGEX] [--limit N]

The types come from the build (<build>/lcmtypes/python, put it on PYTHONPATH) or an install
(<prefix>/lib/python3/dist-packages). The log is read with the `lcm` module's EventLog when that
module is importable (Debian 12 packages no Python bindings for LCM), otherwise with the few
lines below, which follow LCM's log format.
"""
import argparse
import re
import struct
import sys

import kestrel  # the generated types; every one is an attribute of the package

SYNC = 0xEDA1DA01


def events(path):
    """Yields (timestamp_us, channel, data) for every event of the log at `path`."""
    try:
        import lcm
    except ImportError:
        lcm = None
    if lcm is not None:
        for e in lcm.EventLog(path, "r"):
            yield e.timestamp, e.channel, e.data
        return
    with open(path, "rb") as f:
        while True:
            header = f.read(28)
            if len(header) < 28:
                return
            sync, _number, utime, channel_len, data_len = struct.unpack(">IqqII", header)
            if sync != SYNC:
                raise ValueError(f"{path}: bad sync word at byte {f.tell() - 28}")
            channel = f.read(channel_len).decode("utf-8")
            yield utime, channel, f.read(data_len)


def decoders():
    """Maps the 8-byte fingerprint each encoded message starts with to its type."""
    table = {}
    for name in dir(kestrel):
        t = getattr(kestrel, name)
        if isinstance(t, type) and hasattr(t, "_get_packed_fingerprint"):
            table[t._get_packed_fingerprint()] = t
    return table


def text(value, limit=8):
    """A field's value, short: long arrays cut after `limit` items, bytes counted."""
    if isinstance(value, (bytes, bytearray)):
        return f"<{len(value)} bytes>"
    if isinstance(value, (list, tuple)):
        items = [text(v) for v in value[:limit]]
        more = f", ...({len(value)})" if len(value) > limit else ""
        return "[" + ", ".join(items) + more + "]"
    if hasattr(value, "__slots__"):
        return "{" + " ".join(f"{k}={text(getattr(value, k))}" for k in value.__slots__) + "}"
    if isinstance(value, str):
        return repr(value)
    return str(value)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("log")
    parser.add_argument("--channel", default=".*", help="only channels matching this regex")
    parser.add_argument("--limit", type=int, default=0, help="stop after N printed messages")
    args = parser.parse_args()
    table = decoders()
    channel_re = re.compile(args.channel)
    first = None
    printed = 0
    for utime, channel, data in events(args.log):
        first = utime if first is None else first
        if not channel_re.fullmatch(channel):
            continue
        t = table.get(data[:8])
        if t is None:
            print(f"{(utime - first) * 1e-6:.6f} {channel} <not a kestrel type: {len(data)} bytes>")
        else:
            m = t.decode(data)
            fields = " ".join(f"{k}={text(getattr(m, k))}" for k in m.__slots__)
            print(f"{(utime - first) * 1e-6:.6f} {channel} kestrel.{t.__name__} {fields}")
        printed += 1
        if args.limit and printed >= args.limit:
            break
    return 0


if __name__ == "__main__":
    sys.exit(main())
