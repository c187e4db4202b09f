#!/usr/bin/env python3
"""An independent bot-procman sheriff against kestrel-procman (docs/protocols.md section 5).

Nothing here comes from lcm-gen or from Kestrel's C++: the fingerprints are computed from the
.lcm definitions with LCM's hashing rule written out in Python, messages are encoded and decoded
from those definitions with the struct module, and they travel as raw LCM UDP datagrams
("LC02" header, channel, payload) on the multicast group (bot_procman_wire.py). The sheriff asks for reports
(discovery_t), starts a command of the runner's sheet with an orders2_t, reads its output on
PMD_PRINTF, and stops it.

Usage: bot_procman_wire_test.py LCMTYPES_DIR KESTREL_PROCMAN   (inside a private network
namespace: tests/tools/in_netns.sh)
"""
import os
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bot_procman_wire import GROUP, PORT, Wire, decode, encode, fingerprint, parse_types  # noqa: E402

# The fingerprints libbot2's own deputy and sheriff put on the wire (docs/protocols.md 5.1).
EXPECTED = {"info2_t": 0xd0cf2ed34edd8314, "orders2_t": 0xef1277a9fdb17943,
            "printf_t": 0x0abac44d8e3a7bad, "discovery_t": 0x1116e1fff6333a71}


def fail(why):
    print("FAIL: " + why)
    sys.exit(1)


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
