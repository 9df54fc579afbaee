#!/usr/bin/env bash
# Installs what peeltrim needs on a fresh Debian 12 machine: the Vulkan loader,
# Mesa's lavapipe (software Vulkan 1.3), the Khronos validation layers, and a
# virtual X server (xvfb: the viewer's test runs a window without a display).
# Idempotent: does nothing when everything is already installed.
#
#   tools/setup.sh             # the above
#   tools/setup.sh --openscad  # also OpenSCAD (to read .scad files directly, and
#                              # for tools/openscad_truth.py); off by default
set -euo pipefail
pkgs=(mesa-vulkan-drivers libvulkan1 vulkan-validationlayers xvfb xauth)
for arg in "$@"; do
  case "$arg" in
    --openscad) pkgs+=(openscad) ;;
    *) echo "tools/setup.sh: unknown option '$arg' (known: --openscad)" >&2; exit 2 ;;
  esac
done
missing=()
for p in "${pkgs[@]}"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "tools/setup.sh: installing ${missing[*]}" >&2
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
