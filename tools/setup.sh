#!/bin/bash
# Idempotent set-up of a Debian 12 machine for this workspace:
#   1. the Debian packages of deps/debian.txt (apt-get update + install only if some are missing),
#   2. the pinned PyPI packages of deps/requirements.txt for /usr/bin/python3 (only if a pin differs).
# Runs as root, or through sudo otherwise. Non-interactive.
set -euo pipefail
ws="$(cd "$(dirname "$0")/.." && pwd)"
sudo=""
if [ "$(id -u)" != 0 ]; then sudo="sudo"; fi

mapfile -t wanted < <(sed -e 's/#.*//' -e 's/[[:space:]]//g' "$ws/deps/debian.txt" | grep -v '^$')
missing=()
for pkg in "${wanted[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$pkg")
  fi
done
if [ "${#missing[@]}" -gt 0 ]; then
  echo "setup: installing ${#missing[@]} Debian packages: ${missing[*]}"
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -q
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -q "${missing[@]}"
else
  echo "setup: all ${#wanted[@]} Debian packages present"
fi

# Pinned PyPI packages for Debian's python itself, so that roslaunch (which runs
# `xacro`) and the tests find them from any shell. PEP 668 needs the override flag.
need_pip=0
while read -r pin; do
  name="${pin%%==*}"; version="${pin##*==}"
  have="$(/usr/bin/python3 -m pip show "$name" 2>/dev/null | sed -n 's/^Version: //p' || true)"
  if [ "$have" != "$version" ]; then need_pip=1; fi
done < <(sed -e 's/#.*//' -e 's/[[:space:]]//g' "$ws/deps/requirements.txt" | grep -v '^$')
if [ "$need_pip" = 1 ]; then
  echo "setup: installing pinned PyPI packages"
  $sudo /usr/bin/python3 -m pip install -q --disable-pip-version-check --break-system-packages \
    -r "$ws/deps/requirements.txt"
else
  echo "setup: pinned PyPI packages present"
fi
