#!/usr/bin/env bash
# The main job (the README's first quick-start command): renders every shipped
# scene with every algorithm, writes the images, out/summary.md (speed against
# error) and out/plots/, and prints the table. Extra arguments go to
# `peeltrim bench` (e.g. --frames 10 --all-depths).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
cargo build --release --quiet
exec target/release/peeltrim bench --algos all --frames 5 --size 400x400 --out out "$@"
