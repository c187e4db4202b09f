"""bot-procman on the wire, written from libbot2's message definitions alone (docs/protocols.md
section 5): the types are parsed from the .lcm files, fingerprints computed with LCM's hashing
rule written out here, messages encoded and decoded with the struct module, and carried as raw
LCM UDP datagrams ("LC02" header, channel, payload) on the multicast group. Nothing comes from
lcm-gen or from Kestrel's C++: the sheriff test (bot_procman_wire_test.py) and the protocol-only
deputy (bot_procman_deputy.py) use it to check Kestrel's side independently.
"""
import re
import os
import socket
import struct

GROUP, PORT = "239.255.76.67", 7667
PRIMITIVES = {"int8_t": "b", "int16_t": "h", "int32_t": "i", "int64_t": "q", "float": "f",
              "double": "d", "boolean": "b", "byte": "B"}
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
            raise ValueError("%s.%s holds %d, %s says %d" % (name, field, len(items), dims[0],
                                                             count))
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

    def __init__(self, timeout_s=0.2):
        self.rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
        self.rx.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.rx.bind(("", PORT))
        mreq = struct.pack("4s4s", socket.inet_aton(GROUP), socket.inet_aton("0.0.0.0"))
        self.rx.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, mreq)
        self.rx.settimeout(timeout_s)
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
