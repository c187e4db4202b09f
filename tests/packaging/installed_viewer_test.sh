#!/usr/bin/env bash
# The installed kestrel-viewer serves the installed page (<prefix>/share/kestrel/web, found
# relative to its own folder) on 127.0.0.1: index.html fetched over HTTP equals the installed file.
# Usage: installed_viewer_test.sh PREFIX
set -euo pipefail
prefix=$1
viewer="$prefix/bin/kestrel-viewer"
[[ -x $viewer ]] || { echo "no installed kestrel-viewer: skipped"; exit 77; }
work=$(mktemp -d)
trap 'kill $pid 2>/dev/null || true; rm -rf "$work"' EXIT
"$viewer" --config "$prefix/share/kestrel/config/viewer.yaml" --lcm-url memq:// --set port=0 --set foxglove.port=0 \
  2>"$work/viewer.log" &
pid=$!
for _ in $(seq 50); do
  grep -q "serving http://" "$work/viewer.log" && break
  sleep 0.1
done
line=$(grep -o "serving http://[^ ]* from .*" "$work/viewer.log" || true)
echo "$line"
[[ $line == *" from $prefix/share/kestrel/web" ]] ||
  { cat "$work/viewer.log"; echo "FAIL: not serving the installed page"; exit 1; }
url=$(echo "$line" | sed -E 's/serving (http:[^ ]*) from .*/\1/')
/usr/bin/python3 -c 'import sys, urllib.request; sys.stdout.buffer.write(urllib.request.urlopen(sys.argv[1] + "index.html", timeout=10).read())' \
  "$url" >"$work/index.html"
cmp "$work/index.html" "$prefix/share/kestrel/web/index.html" || { echo "FAIL: index.html differs"; exit 1; }
echo "PASS: the installed viewer serves $prefix/share/kestrel/web"
