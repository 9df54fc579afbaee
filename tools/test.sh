#!/usr/bin/env bash
# The project's test command (the README's second quick-start command, and CI's):
# installs the Vulkan packages if missing, then runs every test, the GPU tests
# in vk_tests/ included (on lavapipe, with validation layers; a validation
# message fails a test).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
cargo test "$@"
