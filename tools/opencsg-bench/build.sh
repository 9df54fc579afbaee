#!/usr/bin/env bash
# Builds tools/opencsg-bench/opencsg-bench, the OpenCSG baseline that
# `peeltrim bench --baseline opencsg` runs. OpenCSG is GPL: this program is
# separate and is never linked into the peeltrim library or binary.
# Installs its Debian 12 packages first (idempotent, like tools/setup.sh).
set -euo pipefail
cd "$(dirname "$0")"
pkgs=(g++ make libopencsg-dev libglew-dev libegl-dev libgl-dev libegl-mesa0 libgl1-mesa-dri)
missing=()
for p in "${pkgs[@]}"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if [ ${#missing[@]} -ne 0 ]; then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  echo "tools/opencsg-bench/build.sh: installing ${missing[*]}" >&2
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
make -s
echo "built $(pwd)/opencsg-bench" >&2
