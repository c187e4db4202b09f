#!/usr/bin/env bash
# kestrel-mcap-export on the report fixture's recorded mission, read back by the mcap library's own
# readers (tests/viewer/mcap_read_check.mjs: @mcap/core's indexed and stream readers, every CRC
# checked): both readers agree, every topic holds as many messages as the exporter wrote, every
# message is JSON, and the file is zstd-chunked. Skipped (77) with the reason where node or the
# npm packages are missing (scripts/setup installs them when it can reach the npm registry); a file
# that is no LCM log is refused with a clear error.
# Usage: mcap_export_test.sh KESTREL_MCAP_EXPORT FIXTURE_DIR SOURCE_ROOT WORK_DIR
set -euo pipefail
exporter=$1 fixture=$2 root=$3 work=$4
rm -rf "$work" && mkdir -p "$work"
# Bad input: a clear error, exit 1, no file left behind.
head -c 3000 /dev/urandom >"$work/garbage.lcmlog"
if "$exporter" --log "$work/garbage.lcmlog" --out "$work/garbage.mcap" 2>"$work/garbage.err"; then
  echo "FAIL: a file of random bytes was exported"; exit 1
fi
grep -q "not an LCM log" "$work/garbage.err" || { echo "FAIL: $(cat "$work/garbage.err")"; exit 1; }
[[ ! -e $work/garbage.mcap ]] || { echo "FAIL: garbage.mcap left behind"; exit 1; }
command -v node >/dev/null || { echo "KESTREL-SKIP: no node (apt-get install nodejs)"; exit 77; }
[[ -d $root/viewer/web/node_modules/@mcap/core && -d $root/viewer/web/node_modules/fzstd ]] || {
  echo "KESTREL-SKIP: @mcap/core or fzstd not in viewer/web/node_modules (scripts/setup runs npm ci)"
  exit 77
}
"$exporter" --log "$fixture/combined.lcmlog" --out "$work/run.mcap" >"$work/export.txt"
cat "$work/export.txt"
node "$root/tests/viewer/mcap_read_check.mjs" "$work/run.mcap" >"$work/read.json"
/usr/bin/python3 - "$work/export.txt" "$work/read.json" <<'PY'
import json, re, sys
written = {}
for line in open(sys.argv[1]).read().splitlines()[1:]:
    topic, count = line.split()
    written[topic] = int(count)
read = json.load(open(sys.argv[2]))
assert read["agree"], "the indexed and the stream reader disagree"
got = {topic: t["count"] for topic, t in read["indexed"]["topics"].items()}
assert got == written, f"messages per topic: read {got}, written {written}"
assert read["indexed"]["jsonErrors"] == 0, "a message is not JSON"
assert int(read["indexed"]["statisticsMessageCount"]) == sum(written.values())
for topic in ("/map", "/tf", "/trajectory", "/candidates"):
    assert written.get(topic, 0) > 0, f"no {topic} message"
for process in ("sim", "controller", "mapper", "explorer"):  # the run's configuration
    assert written.get(f"/params/{process}") == 1, f"no /params/{process}"
schemas = {c["topic"]: c["schema"] for c in read["indexed"]["channels"]}
assert schemas["/tf"] == "foxglove.FrameTransform" and schemas["/map"] == "foxglove.SceneUpdate"
print(f"read back by @mcap/core: {sum(written.values())} messages on {len(written)} topics, "
      f"{read['indexed']['chunks']} chunks, both readers agree")
PY
