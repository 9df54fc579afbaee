#!/usr/bin/env bash
# The main job (the README's first quick-start command): renders every shipped
# scene with every algorithm, writes the images, out/summary.md (speed against
# error) and out/plots/, and prints the table. Extra arguments go to
# `peeltrim bench` (e.g. --frames 10 --all-depths).
#
# The OpenCSG baseline (a separate GPL program, tools/opencsg-bench) runs in the
# same bench when it can be built; it is an optional extra, so a failed build is
# a warning and the bench then says "not run" with how to build it.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
cargo build --release --quiet
tools/opencsg-bench/build.sh \
  || echo "demo.sh: warning: the OpenCSG baseline could not be built; the bench runs without it" >&2
# Shadows and interference on their shipped scenes: optional extras.
for s in shadow_block interference; do
  target/release/peeltrim render "scenes/$s.toml" --algo cst-i --size 400x400 --out "out/extras/$s" \
    || echo "demo.sh: warning: rendering scenes/$s.toml failed" >&2
done
exec target/release/peeltrim bench --algos all --frames 5 --size 400x400 --out out --baseline opencsg "$@"
