#!/usr/bin/env python3
"""An independent bot-procman sheriff against kestrel-procman (docs/protocols.md section 5).

Nothing here comes from lcm-gen or from Kestrel's C++: the fingerprints are computed from the
.lcm definitions with LCM's hashing rule written out in Python, messages are encoded and decoded
from those definitions with the struct module, and they travel as raw LCM UDP datagrams
("LC02" header, channel, payload) on the multicast group. The sheriff asks for reports
(discovery_t), starts a command of the runner's sheet with an orders2_t, reads its output on
PMD_PRINTF, and stops it.

Usage: bot_procman_wire_test.py LCMTYPES_DIR KESTREL_PROCMAN   (inside a private network
namespace: tests/tools/in_netns.sh)
"""
import os
import re
import socket
import struct
import subprocess
import sys
import tempfile
import time

GROUP, PORT = "239.255.76.67", 7667
PRIMITIVES = {"int8_t": "b", "int16_t": "h", "int32_t": "i", "int64_t": "q", "float": "f",
              "double": "d", "boolean": "b", "byte": "B"}
# The fingerprints libbot2's own deputy and sheriff put on the wire (docs/protocols.md 5.1).
EXPECTED = {"info2_t": 0xd0cf2ed34edd8314, "orders2_t": 0xef1277a9fdb17943,
            "printf_t": 0x0abac44d8e3a7bad, "discovery_t": 0x1116e1fff6333a71}


def fail(why):
    print("FAIL: " + why)
    sys.exit(1)


def parse_types(folder):
    """{struct name: [(type, name, [dims])]} from every .lcm file of the folder."""
    types = {}
    for f in sorted(os.listdir(folder)):
        if not f.endswith(".lcm"):
            continue
        text = re.sub(r"//[^\n]*", "", open(os.path.join(folder, f)).read())
        m = re.search(r"struct\s+(\w+)\s*\{(.*)\}", text, re.S)
        fields = []
        for decl in m.group(2).split(";"):
            words = decl.split()
            if not words or words[0] == "const":
                continue
            name_dims = " ".join(words[1:])
            name = re.match(r"(\w+)", name_dims).group(1)
            fields.append((words[0], name, re.findall(r"\[\s*(\w+)\s*\]", name_dims)))
        types[m.group(1)] = fields
    return types


def signed64(v):
    v &= (1 << 64) - 1
    return v - (1 << 64) if v >> 63 else v


def hash_update(v, c):
    # v = ((v << 8) ^ (v >> 55)) + c on a signed 64-bit value (arithmetic shift), as lcm-gen.
    return signed64(((v << 8) ^ (v >> 55)) + c)


def hash_string(v, s):
    v = hash_update(v, len(s))
    for ch in s:
        v = hash_update(v, ord(ch))
    return v


def base_hash(fields):
    v = 0x12345678
    for type_name, name, dims in fields:
        v = hash_string(v, name)
        if type_name in PRIMITIVES or type_name == "string":
            v = hash_string(v, type_name)
        v = hash_update(v, len(dims))
        for d in dims:
            v = hash_update(v, 0 if d.isdigit() else 1)
            v = hash_string(v, d)
    return v


def fingerprint(types, name, parents=()):
    if name in parents:
        return 0
    h = base_hash(types[name]) & ((1 << 64) - 1)
    for type_name, _, _ in types[name]:
        if type_name in types:
            h += fingerprint(types, type_name, parents + (name,))
    h &= (1 << 64) - 1
    return ((h << 1) + (h >> 63)) & ((1 << 64) - 1)


def encode(types, name, msg, top=True):
    out = struct.pack(">Q", fingerprint(types, name)) if top else b""
    for type_name, field, dims in types[name]:
        values = msg[field]
        count = msg[dims[0]] if dims else None
        items = values if dims else [values]
        if dims and len(items) != count:
            fail("%s.%s holds %d, %s says %d" % (name, field, len(items), dims[0], count))
        for v in items:
            if type_name == "string":
                b = v.encode() + b"\0"
                out += struct.pack(">i", len(b)) + b
            elif type_name in PRIMITIVES:
                out += struct.pack(">" + PRIMITIVES[type_name], v)
            else:
                out += encode(types, type_name, v, top=False)
    return out


def decode(types, name, data, pos=0, top=True):
    if top:
        (h,) = struct.unpack_from(">Q", data, 0)
        if h != fingerprint(types, name):
            raise ValueError("%s: fingerprint %#x" % (name, h))
        pos = 8
    msg = {}
    for type_name, field, dims in types[name]:
        n = msg[dims[0]] if dims else 1
        values = []
        for _ in range(n):
            if type_name == "string":
                (length,) = struct.unpack_from(">i", data, pos)
                values.append(data[pos + 4:pos + 4 + length - 1].decode(errors="replace"))
                pos += 4 + length
            elif type_name in PRIMITIVES:
                fmt = ">" + PRIMITIVES[type_name]
                (v,) = struct.unpack_from(fmt, data, pos)
                values.append(v)
                pos += struct.calcsize(fmt)
            else:
                v, pos = decode(types, type_name, data, pos, top=False)
                values.append(v)
        msg[field] = values if dims else values[0]
    return (msg, pos) if not top else msg


class Wire:
    """Raw LCM over UDP multicast: small messages, 'LC02' framing."""

    def __init__(self):
        self.rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
        self.rx.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.rx.bind(("", PORT))
        mreq = struct.pack("4s4s", socket.inet_aton(GROUP), socket.inet_aton("0.0.0.0"))
        self.rx.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, mreq)
        self.rx.settimeout(0.2)
        self.tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
        self.tx.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
        self.seq = 0

    def publish(self, channel, payload):
        self.seq += 1
        self.tx.sendto(struct.pack(">II", 0x4C433032, self.seq) + channel.encode() + b"\0" +
                       payload, (GROUP, PORT))

    def receive(self):
        try:
            data = self.rx.recv(65536)
        except socket.timeout:
            return None, None
        magic, _ = struct.unpack_from(">II", data, 0)
        if magic != 0x4C433032:
            return None, None  # a fragment of a large message: none of the runner's
        end = data.index(b"\0", 8)
        return data[8:end].decode(), data[end + 1:]


def main():
    types = parse_types(sys.argv[1])
    for name, value in EXPECTED.items():
        got = fingerprint(types, name)
        if got != value:
            fail("%s: fingerprint %#018x from the definitions, libbot2's is %#018x" %
                 (name, got, value))
    print("fingerprints from the .lcm definitions match libbot2's: " +
          ", ".join("%s %#018x" % (n, v) for n, v in EXPECTED.items()))

    folder = tempfile.mkdtemp()
    sheet = os.path.join(folder, "wire.procman")
    with open(sheet, "w") as f:
        f.write('cmd "talker" { exec = "sh -c \'echo hello-wire; exec sleep 30\'"; host = "py"; '
                'stop_signal = 15; }\n')
    env = dict(os.environ, LCM_DEFAULT_URL="udpm://%s:%d?ttl=0" % (GROUP, PORT))
    runner = subprocess.Popen([sys.argv[2], sheet, "--host", "py", "--log-dir", folder],
                              env=env, stderr=open(os.path.join(folder, "runner.err"), "w"))
    wire = Wire()
    reports, printed, discovered = [], [], []

    def listen(seconds, done):
        end = time.time() + seconds
        while time.time() < end:
            channel, payload = wire.receive()
            if channel == "PMD_INFO2":
                reports.append(decode(types, "info2_t", payload))
            elif channel == "PMD_PRINTF":
                printed.append(decode(types, "printf_t", payload))
            elif channel == "PMD_DISCOVER":
                discovered.append(decode(types, "discovery_t", payload))
            if done():
                return True
        return False

    try:
        if not listen(3.0, lambda: any(r["host"] == "py" for r in reports)):
            fail("no info2_t from the runner")
        if not any(d["host"] == "py" for d in discovered):
            fail("no discovery_t from the runner at its start")
        talker = [c for c in reports[-1]["cmds"] if c["cmd"]["command_name"] == "talker"][0]
        print("report: host %s, %d command(s), talker sheriff_id %d pid %d runid %d, exec [%s]" %
              (reports[-1]["host"], reports[-1]["ncmds"], talker["sheriff_id"], talker["pid"],
               talker["actual_runid"], talker["cmd"]["exec_str"]))
        if talker["pid"] != 0 or talker["cmd"]["stop_signal"] != 15:
            fail("unexpected report %r" % talker)

        def orders(desired_runid, force_quit):
            cmd = dict(talker["cmd"], num_options=0, option_names=[], option_values=[])
            return encode(types, "orders2_t", {
                "utime": int(time.time() * 1e6), "host": "py", "sheriff_name": "python-sheriff",
                "ncmds": 1, "cmds": [{"cmd": cmd, "desired_runid": desired_runid,
                                      "force_quit": force_quit,
                                      "sheriff_id": talker["sheriff_id"]}],
                "num_options": 0, "option_names": [], "option_values": []})

        def talker_now():
            for c in reports[-1]["cmds"]:
                if c["sheriff_id"] == talker["sheriff_id"]:
                    return c
            return None

        start = orders(talker["actual_runid"] + 1, 0)
        end = time.time() + 5
        while time.time() < end and not (talker_now() and talker_now()["pid"] > 0):
            wire.publish("PMD_ORDERS2", start)  # re-sent each second, as a sheriff does
            listen(1.0, lambda: talker_now() is not None and talker_now()["pid"] > 0)
        started = talker_now()
        if not started or started["pid"] <= 0:
            fail("the runner did not start talker on the sheriff's orders")
        if started["actual_runid"] != talker["actual_runid"] + 1:
            fail("runid %d, ordered %d" % (started["actual_runid"], talker["actual_runid"] + 1))
        listen(2.0, lambda: "hello-wire" in "".join(p["text"] for p in printed))
        text = "".join(p["text"] for p in printed if p["sheriff_id"] == talker["sheriff_id"])
        if "hello-wire\n" not in text or any(p["deputy_name"] != "py" for p in printed):
            fail("talker's output on PMD_PRINTF: %r" % text)
        print("started: pid %d, runid %d; PMD_PRINTF: %r" %
              (started["pid"], started["actual_runid"], text))

        stop = orders(started["actual_runid"], 1)
        end = time.time() + 5
        while time.time() < end and talker_now()["pid"] != 0:
            wire.publish("PMD_ORDERS2", stop)
            listen(1.0, lambda: talker_now()["pid"] == 0)
        stopped = talker_now()
        status = stopped["exit_code"]
        if stopped["pid"] != 0 or not os.WIFSIGNALED(status) or os.WTERMSIG(status) != 15:
            fail("not stopped by SIGTERM: %r" % stopped)
        print("stopped: exit_code %#x (the raw wait status: signal %d)" %
              (status, os.WTERMSIG(status)))
        print("PASS")
    finally:
        runner.terminate()
        runner.wait(timeout=10)


if __name__ == "__main__":
    main()
