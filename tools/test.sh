#!/usr/bin/env bash
# The project's test command (the README's second quick-start command, and CI's):
# installs the Vulkan packages if missing, then runs every test, the GPU tests
# in vk_tests/ included (on lavapipe, with validation layers; a validation
# message fails a test).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
# The GPU tests run in parallel (cargo's default). They once died of SIGSEGV in
# parallel runs: the validation layer's global table of instances and devices is
# rewritten without a lock when one is created or destroyed, while other threads'
# calls read it (src/vk/layer_lock.rs serializes that; vk_tests/concurrency.rs
# reproduces the crash without the lock). `RUST_TEST_THREADS=1 tools/test.sh`
# still runs them one at a time.
cargo test "$@"
# The GPU tests again under the hardware device profile
# (`src/vk/profile.rs`): on lavapipe that runs the hardware paths — load-op
# clears, frame timestamps after the frame's commands, no depth-equal shades —
# with a hardware GPU's 8-bit vertex snapping emulated, validation on.
PEELTRIM_DEVICE_PROFILE=hardware cargo test -p peeltrim-cli --test vk_tests "$@"
PEELTRIM_DEVICE_PROFILE=hardware cargo test -p peeltrim --test embed "$@"
# The GPU tests and the embedding example's tests again on SwiftShader, a
# second Vulkan implementation that shares no code with lavapipe (it snaps
# vertices like hardware and has no D24S8),
# where a checkout has it beside it (CI does); a fresh clone does not.
swiftshader_icd="$(pwd)/../shared/swiftshader/vk_swiftshader_icd.json"
if [ -f "$swiftshader_icd" ]; then
    swiftshader_icd="$(cd "$(dirname "$swiftshader_icd")" && pwd)/$(basename "$swiftshader_icd")"
    VK_ICD_FILENAMES="$swiftshader_icd" cargo test -p peeltrim-cli --test vk_tests "$@"
    VK_ICD_FILENAMES="$swiftshader_icd" cargo test -p peeltrim --test embed "$@"
    VK_ICD_FILENAMES="$swiftshader_icd" cargo test -p peeltrim-cli --test cli "$@"
else
    echo "SwiftShader runs skipped: no ../shared/swiftshader/vk_swiftshader_icd.json beside this checkout"
fi
# The embedding example as a program (a host with its own device and the
# validation layer; exits non-zero on a mismatch or any validation message).
# tests/embed.rs runs the same code as tests.
cargo run -q --example embed
