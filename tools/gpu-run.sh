#!/usr/bin/env bash
# The hardware-GPU performance run, in two halves
# (the GPU machine has no cargo, no Vulkan loader and no network, and little
# time there).
#
#   tools/gpu-run.sh prepare          # here: build, strip, download the debs
#   tools/gpu-run.sh run [options]    # there (or here, as a dry run)
#
# prepare (needs cargo, apt-get download, g++ for the OpenCSG baseline):
#   - release `peeltrim` and the GPU test binary (`vk_tests`), stripped, and
#     `opencsg-bench`, into .gpu/bin/;
#   - Debian's Vulkan loader and GL/EGL dispatch libraries, OpenCSG's and GLEW's
#     runtime libraries into .gl/, the validation layers into .gl/vvl/;
#   - .gl/ and .gpu/ are ignored (.gitignore): build outputs, carried to the
#     device machine by naming them (`carry: [".gpu", ".gl"]`).
#
# run (needs only the working tree, .gpu/ and .gl/):
#   - unpacks the debs into a private prefix (never into /), points the loader,
#     EGL and the validation layers at it;
#   - prints the device; runs the GPU test suite on it
#     (PEELTRIM_TEST_DEVICE=auto, validation on); runs the bench table at
#     800×800 against OpenCSG on every shipped scene, plus block minus n
#     spheres and the 311-primitive deep tree;
#   - writes everything under $OUT (default gpu-out/): vk_tests.txt,
#     bench/summary.md, results.json, results.csv, plots; no images.
# Options of run: --device auto|gpu|cpu (default auto), --size WxH (800x800),
#   --frames N (10), --scenes "a.toml b.toml" (all shipped), --families
#   "block-spheres:16,64,256,1024 deep-tree:311" ('' for none), --no-tests,
#   --test-threads N (4).
# Dry run here (lavapipe, small): tools/gpu-run.sh run --device cpu --size 64x64
#   --frames 2 --scenes scenes/complex.toml --families block-spheres:4,16
#   --test-threads 1 -- <a vk_tests filter>
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

prepare() {
    mkdir -p .gpu/bin .gl/vvl
    cargo build --release --bin peeltrim
    strip -o .gpu/bin/peeltrim target/release/peeltrim
    # The tests' binary (dev profile: validation layers are on in every test).
    local test_bin
    test_bin=$(cargo test --no-run --test vk_tests --message-format=json 2>/dev/null |
        sed -n 's/.*"executable":"\([^"]*vk_tests[^"]*\)".*/\1/p' | tail -1)
    [ -n "$test_bin" ] || { echo "gpu-run.sh: no vk_tests binary" >&2; exit 1; }
    strip -o .gpu/bin/vk_tests "$test_bin"
    if tools/opencsg-bench/build.sh; then
        cp tools/opencsg-bench/opencsg-bench .gpu/bin/
    else
        echo "gpu-run.sh: no OpenCSG baseline (tools/opencsg-bench/build.sh failed)" >&2
    fi
    (
        cd .gl
        rm -f ./*.deb vvl/*.deb
        apt-get download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 \
            libgles2 libopencsg1 libglew2.2
        cd vvl && apt-get download vulkan-validationlayers
    )
    du -sh .gpu .gl
}

run() {
    local device=auto size=800x800 frames=10 tests=1 threads=4
    local scenes="" families="block-spheres:16,64,256,1024 deep-tree:311"
    while [ $# -gt 0 ]; do
        case "$1" in
        --device) device=$2; shift 2 ;;
        --size) size=$2; shift 2 ;;
        --frames) frames=$2; shift 2 ;;
        --scenes) scenes=$2; shift 2 ;;
        --families) families=$2; shift 2 ;;
        --no-tests) tests=0; shift ;;
        --test-threads) threads=$2; shift 2 ;;
        --) shift; break ;;
        *) echo "gpu-run.sh run: unknown option '$1' (see the header of $0)" >&2; exit 2 ;;
        esac
    done
    local bin=.gpu/bin
    [ -x $bin/peeltrim ] || { echo "gpu-run.sh: $bin/peeltrim missing: run 'tools/gpu-run.sh prepare' first" >&2; exit 1; }
    local out=${OUT:-gpu-out}
    mkdir -p "$out"
    # A private prefix: the system's libraries stay untouched.
    local gl=/tmp/peeltrim-gl
    rm -rf "$gl" && mkdir -p "$gl/vvl"
    for f in .gl/*.deb; do dpkg -x "$f" "$gl"; done
    for f in .gl/vvl/*.deb; do dpkg -x "$f" "$gl/vvl"; done
    export LD_LIBRARY_PATH="$gl/usr/lib/x86_64-linux-gnu:$gl/vvl/usr/lib/x86_64-linux-gnu${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
    export VK_LAYER_PATH="$gl/vvl/usr/share/vulkan/explicit_layer.d"
    # NVIDIA's ICD and EGL vendor file where the H200 machine keeps them: the
    # loader found the ICD by itself there; name it only if it did not.
    local nv=/usr/local/nvidia/share
    if [ "$device" != cpu ] && [ -z "${VK_DRIVER_FILES:-}" ] &&
        ! $bin/peeltrim render scenes/coincident.toml --algo goldfeather --device gpu \
            --size 16x16 --out /tmp/peeltrim-probe >/dev/null 2>&1 &&
        [ -f $nv/vulkan/icd.d/nvidia_icd.json ]; then
        export VK_DRIVER_FILES=$nv/vulkan/icd.d/nvidia_icd.json
    fi
    if [ -f $nv/glvnd/egl_vendor.d/10_nvidia.json ] && [ "$device" != cpu ]; then
        export __EGL_VENDOR_LIBRARY_FILENAMES=$nv/glvnd/egl_vendor.d/10_nvidia.json
    fi
    [ "$device" = cpu ] && export OPENCSG_BENCH_EGL=surfaceless
    {
        echo "date: $(date -u)"
        echo "host: $(uname -a)"
        command -v nvidia-smi >/dev/null && nvidia-smi -L || true
        echo "device: $device, size: $size, frames: $frames"
    } | tee "$out/env.txt"
    if [ "$tests" = 1 ]; then
        [ -x $bin/vk_tests ] || { echo "gpu-run.sh: $bin/vk_tests missing" >&2; exit 1; }
        local test_device=$device
        [ "$device" = cpu ] || test_device=auto
        # The tests read the scenes of this tree (not the build machine's path).
        PEELTRIM_TEST_DEVICE=$test_device PEELTRIM_TEST_SCENES="$root/scenes" \
            $bin/vk_tests --test-threads "$threads" "$@" 2>&1 | tee "$out/vk_tests.txt" ||
            echo "gpu-run.sh: some GPU tests failed (see $out/vk_tests.txt); the bench runs anyway" >&2
    fi
    local scene_args=()
    # shellcheck disable=SC2206
    [ -n "$scenes" ] && scene_args=($scenes)
    local family_args=()
    for f in $families; do family_args+=(--family "$f"); done
    local baseline=()
    if [ -x $bin/opencsg-bench ]; then
        baseline=(--baseline opencsg --opencsg-bench $bin/opencsg-bench)
    else
        echo "gpu-run.sh: $bin/opencsg-bench missing: the bench runs without OpenCSG" >&2
    fi
    # Standard Z with D32S8; without
    # validation layers (they multiply the CPU cost of recording; the tests
    # above ran with them).
    $bin/peeltrim bench "${scene_args[@]}" "${family_args[@]}" --size "$size" \
        --frames "$frames" --device "$device" --no-images \
        --depth-format d32s8 --standard-z "${baseline[@]}" --out "$out/bench" 2>&1 |
        tee "$out/bench.txt"
    rm -rf "$out/bench/opencsg"
    echo "gpu-run.sh: done; results in $out/"
}

case "${1:-}" in
prepare) shift; prepare "$@" ;;
run) shift; run "$@" ;;
*) echo "usage: tools/gpu-run.sh prepare | run [options] (see the header of $0)" >&2; exit 2 ;;
esac
