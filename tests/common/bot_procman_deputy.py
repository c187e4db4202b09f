#!/usr/bin/env python3
"""A protocol-only bot-procman deputy, for tests: it speaks bot-procman's messages and nothing of
Kestrel's (no PROCMAN_STATUS, no sheet), as libbot2's bot-procman-deputy does, written from
docs/protocols.md section 5.2 with the independent wire code of bot_procman_wire.py. It starts
with no command; a sheriff's orders2_t create, start, stop and remove them.

What it does: announces itself on PMD_DISCOVER (every 200 ms for 1.5 s; a namesake makes it exit
2), then reports info2_t on PMD_INFO2 every second and after every change, obeys orders2_t for its
name not older than 60 s (per command by sheriff_id: stopped and another runid wanted without
force_quit: start; running and force_quit or another runid: stop; otherwise adopt the runid;
commands the orders leave out are stopped and forgotten), runs each command without a shell
(words split as sh does, leading NAME=value words set the child's environment, $NAME and ${NAME}
expanded from its own), in its own session, its output sent on PMD_PRINTF; stops a command with
its stop signal to its process group and SIGKILL after stop_time_allowed; respawns auto_respawn
commands after 0.1 s; exits 0 on SIGINT or SIGTERM, having stopped every command.

Usage: bot_procman_deputy.py LCMTYPES_DIR --name NAME   (udpm://239.255.76.67:7667, ttl=0;
inside a private network namespace: tests/tools/in_netns.sh)
"""
import argparse
import os
import re
import select
import shlex
import signal
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bot_procman_wire import Wire, decode, encode, parse_types  # noqa: E402

VARIABLE = re.compile(r"\$\{([A-Za-z_][A-Za-z_0-9]*)\}|\$([A-Za-z_][A-Za-z_0-9]*)")


def now_us():
    return int(time.time() * 1e6)


class Command:
    def __init__(self, sheriff_id):
        self.sheriff_id = sheriff_id
        self.cmd = None  # command2_t as ordered
        self.actual_runid = 0
        self.process = None
        self.exit_code = 0  # raw wait status of the last exit
        self.stop_sent = None  # time.time() of the stop signal
        self.wanted = False  # running wanted (for auto_respawn)
        self.respawn_at = None


class Deputy:
    def __init__(self, types, name):
        self.types, self.name = types, name
        self.wire = Wire(timeout_s=0.05)
        self.commands = {}  # by sheriff_id
        self.nonce = os.getpid()
        self.started = time.time()
        self.discovery_done = False
        self.info_due = False
        self.next_info = 0.0
        self.removed = []  # commands forgotten while still stopping

    def publish(self, channel, type_name, msg):
        self.wire.publish(channel, encode(self.types, type_name, msg))

    def printf(self, sheriff_id, text):
        self.publish("PMD_PRINTF", "printf_t", {"utime": now_us(), "deputy_name": self.name,
                                                "sheriff_id": sheriff_id, "text": text})

    def report(self):
        cmds = []
        for c in self.commands.values():
            cmds.append({"cmd": c.cmd, "pid": c.process.pid if c.process else 0,
                         "actual_runid": c.actual_runid, "exit_code": c.exit_code,
                         "cpu_usage": 0.0, "mem_vsize_bytes": 0, "mem_rss_bytes": 0,
                         "sheriff_id": c.sheriff_id})
        self.publish("PMD_INFO2", "info2_t", {
            "utime": now_us(), "host": self.name, "cpu_load": 0.0, "phys_mem_total_bytes": 0,
            "phys_mem_free_bytes": 0, "swap_total_bytes": 0, "swap_free_bytes": 0,
            "ncmds": len(cmds), "cmds": cmds, "num_options": 0, "option_names": [],
            "option_values": []})
        self.info_due = False
        self.next_info = time.time() + 1.0

    def start(self, c):
        try:
            words = shlex.split(c.cmd["exec_str"], comments=True)
        except ValueError:
            words = c.cmd["exec_str"].split()
        env = dict(os.environ)
        while words and re.match(r"[A-Za-z_][A-Za-z_0-9]*=", words[0]):
            key, value = words.pop(0).split("=", 1)
            env[key] = value
        words = [VARIABLE.sub(lambda m: os.environ.get(m.group(1) or m.group(2), m.group(0)), w)
                 for w in words]
        c.exit_code = 0
        c.stop_sent = None
        try:
            c.process = subprocess.Popen(words, env=env, stdin=subprocess.DEVNULL,
                                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                         start_new_session=True)
            os.set_blocking(c.process.stdout.fileno(), False)
        except OSError as e:
            c.process = None
            c.exit_code = 127 << 8
            self.printf(c.sheriff_id, "couldn't start [%s]: %s\n" % (c.cmd["exec_str"], e))
        self.info_due = True

    def stop(self, c):
        c.wanted = False
        c.respawn_at = None
        if c.process and c.stop_sent is None:
            try:
                os.killpg(c.process.pid, c.cmd["stop_signal"] or signal.SIGINT)
            except ProcessLookupError:
                pass
            c.stop_sent = time.time()

    def on_orders(self, orders):
        if not self.discovery_done or orders["host"] != self.name:
            return
        if now_us() - orders["utime"] > 60_000_000:
            for o in orders["cmds"]:
                self.printf(o["sheriff_id"], "ignoring stale orders\n")
            return
        listed = set()
        for o in orders["cmds"]:
            listed.add(o["sheriff_id"])
            c = self.commands.get(o["sheriff_id"])
            if c is None:
                c = self.commands[o["sheriff_id"]] = Command(o["sheriff_id"])
                self.info_due = True
            c.cmd = dict(o["cmd"], num_options=0, option_names=[], option_values=[])
            running = c.process is not None
            other_run = o["desired_runid"] != c.actual_runid
            if not running and other_run and not o["force_quit"]:
                c.actual_runid = o["desired_runid"]
                c.wanted = True
                self.start(c)
            elif running and (o["force_quit"] or other_run):
                self.stop(c)
                self.info_due = True
            else:
                c.actual_runid = o["desired_runid"]
                if o["force_quit"]:
                    c.wanted = False
                    c.respawn_at = None
        for sheriff_id in list(self.commands):
            if sheriff_id not in listed:
                c = self.commands.pop(sheriff_id)
                self.stop(c)
                if c.process:
                    self.removed.append(c)
                self.info_due = True

    def read_output(self, c):
        """Sends what the command wrote (one read, at most 1023 bytes); returns how much."""
        try:
            data = os.read(c.process.stdout.fileno(), 1023)
        except (BlockingIOError, ValueError):
            return 0
        if data:
            self.printf(c.sheriff_id, data.decode(errors="replace"))
        return len(data)

    def reap(self, c):
        if not c.process:
            if c.respawn_at is not None and time.time() >= c.respawn_at and c.wanted:
                c.respawn_at = None
                self.start(c)
            return
        code = c.process.poll()
        if code is None:
            if c.stop_sent is not None and \
                    time.time() - c.stop_sent > c.cmd["stop_time_allowed"]:
                try:
                    os.killpg(c.process.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            return
        while self.read_output(c) > 0:  # what it wrote last
            pass
        c.process.stdout.close()
        c.exit_code = (-code) if code < 0 else (code << 8)  # as waitpid's status
        c.process = None
        self.info_due = True
        if c.wanted and c.cmd["auto_respawn"]:
            c.respawn_at = time.time() + 0.1

    def run(self):
        stopping = []
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, lambda *_: stopping.append(1))
        next_discovery = 0.0
        while not stopping:
            t = time.time()
            if not self.discovery_done:
                if t - self.started >= 1.5:
                    self.discovery_done = True
                    self.info_due = True
                elif t >= next_discovery:
                    self.publish("PMD_DISCOVER", "discovery_t",
                                 {"utime": now_us(), "host": self.name, "nonce": self.nonce})
                    next_discovery = t + 0.2
            pipes = {c.process.stdout.fileno(): c for c in self.commands.values() if c.process}
            readable = select.select(list(pipes), [], [], 0)[0] if pipes else []
            for fd in readable:
                self.read_output(pipes[fd])
            channel, payload = self.wire.receive()
            try:
                if channel == "PMD_ORDERS2":
                    self.on_orders(decode(self.types, "orders2_t", payload))
                elif channel == "PMD_DISCOVER":
                    d = decode(self.types, "discovery_t", payload)
                    if not self.discovery_done and d["host"] == self.name and \
                            d["nonce"] != self.nonce:
                        print("another deputy named %s is running" % self.name, file=sys.stderr)
                        return 2
                    if self.discovery_done:
                        self.info_due = True
                elif channel == "PMD_INFO2" and not self.discovery_done:
                    if decode(self.types, "info2_t", payload)["host"] == self.name:
                        print("another deputy named %s reports" % self.name, file=sys.stderr)
                        return 2
            except (ValueError, IndexError, KeyError) as e:  # not a message of these types
                print("dropped a message on %s: %s" % (channel, e), file=sys.stderr)
            for c in list(self.commands.values()) + self.removed:
                self.reap(c)
            self.removed = [c for c in self.removed if c.process]
            if self.discovery_done and (self.info_due or time.time() >= self.next_info):
                self.report()
        for c in list(self.commands.values()) + self.removed:
            self.stop(c)
        end = time.time() + 5
        while time.time() < end and any(c.process for c in self.commands.values()):
            for c in self.commands.values():
                self.reap(c)
            time.sleep(0.02)
        return 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("types", help="folder of the bot_procman .lcm definitions")
    parser.add_argument("--name", required=True)
    args = parser.parse_args()
    sys.exit(Deputy(parse_types(args.types), args.name).run())


if __name__ == "__main__":
    main()
