#!/usr/bin/env bash
# The project's test command (the README's second quick-start command, and CI's):
# installs the Vulkan packages if missing, then runs every test, the GPU tests
# in vk_tests/ included (on lavapipe, with validation layers; a validation
# message fails a test).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
# One test thread: with two GPU tests at once on lavapipe, the vk_tests process
# died of SIGSEGV in 2 of 4 full runs on this 2-core machine, never in a test's
# assertions and never with one thread (3 of 3 runs). The cause is not yet
# found (a run under gdb did not reproduce it). A caller may still ask for
# more: `tools/test.sh -- --test-threads=2`.
export RUST_TEST_THREADS="${RUST_TEST_THREADS:-1}"
cargo test "$@"
# The embedding example as a program (a host with its own device and the
# validation layer; exits non-zero on a mismatch or any validation message).
# vk_tests/embed.rs runs the same code as tests.
cargo run -q --example embed
