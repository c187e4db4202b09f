#!/bin/bash
# with_oni_plugin.sh REPOSITORY_DIR COMMAND [ARGS...]
#
# Runs COMMAND with Debian's OpenNI2 loading only the drivers in REPOSITORY_DIR (e.g. the folder
# holding Kestrel's libKestrelOni.so.0). Debian's libOpenNI2 reads its configuration from the
# fixed path /etc/openni2/OpenNI.ini and reads no environment variable, so this script enters a
# private mount namespace (unshare -m, needs root or CAP_SYS_ADMIN) and bind-mounts a generated
# OpenNI.ini with "[Drivers] Repository=REPOSITORY_DIR" over that path. The machine's files are
# untouched: the mount exists only inside the namespace and ends with COMMAND.
# Exit status: COMMAND's, or 77 (ctest SKIP_RETURN_CODE) if a mount namespace cannot be made.
set -euo pipefail

if [[ $# -lt 2 ]]; then
  echo "usage: $0 REPOSITORY_DIR COMMAND [ARGS...]" >&2
  exit 2
fi
repo=$(realpath -e "$1")
shift
readonly ini_path=/etc/openni2/OpenNI.ini

if [[ "${KESTREL_ONI_NAMESPACE:-}" != inside ]]; then
  if ! unshare -m --propagation private true 2>/dev/null; then
    echo "$0: cannot create a mount namespace (unshare -m needs root); skipping" >&2
    exit 77
  fi
  exec unshare -m --propagation private env KESTREL_ONI_NAMESPACE=inside "$0" "$repo" "$@"
fi
unset KESTREL_ONI_NAMESPACE

if [[ ! -f "$ini_path" ]]; then
  echo "$0: $ini_path does not exist (is libopenni2-0 installed?)" >&2
  exit 1
fi
tmp=$(mktemp -d /tmp/kestrel-oni.XXXXXX)
cat >"$tmp/OpenNI.ini" <<INI
[Log]
Verbosity=3
LogToConsole=0
LogToFile=0

[Device]

[Drivers]
Repository=$repo
INI
mount --bind "$tmp/OpenNI.ini" "$ini_path"
# The mount keeps the file's inode alive; remove the name now so nothing is left behind, and
# exec so COMMAND receives signals (SIGINT/SIGTERM) directly.
rm -rf "$tmp"
exec "$@"
