#!/usr/bin/env bash
# Builds facesynth and runs the whole test suite twice (README's second command; .ci/run calls it):
#   1. Release, in build/ (FACESYNTH_BUILD_DIR);
#   2. clang-tidy over every non-test .cpp (tools/tidy.sh, the checks in .clang-tidy), with that
#      build's compile commands;
#   3. AddressSanitizer + UndefinedBehaviorSanitizer with leak detection on, in build-asan/
#      (FACESYNTH_ASAN_BUILD_DIR). tools/lsan.supp suppresses leaks inside Mesa's and HDF5's libraries only.
# --quick skips steps 2 and 3 (for local runs); CI runs all three.
set -euo pipefail
cd "$(dirname "$0")/.."
full=1
for arg in "$@"; do
    case $arg in
        --quick) full=0 ;;
        -h|--help) sed -n '2,8p' "$0"; exit 0 ;;
        *) echo "usage: tools/test.sh [--quick]" >&2; exit 2 ;;
    esac
done
bash tools/install-deps.sh

build_dir=${FACESYNTH_BUILD_DIR:-build}
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build "$build_dir" -j2
(cd "$build_dir" && ctest --output-on-failure -j2 --timeout 900)
[[ $full == 1 ]] || exit 0

FACESYNTH_BUILD_DIR=$build_dir bash tools/tidy.sh

# Benchmarks are not built in the sanitizer pass: they are never run by the suite.
asan_dir=${FACESYNTH_ASAN_BUILD_DIR:-build-asan}
cmake -S . -B "$asan_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFACESYNTH_SANITIZE=ON -DFACESYNTH_BUILD_BENCH=OFF
cmake --build "$asan_dir" -j2
export ASAN_OPTIONS=detect_leaks=1
export LSAN_OPTIONS=suppressions=$PWD/tools/lsan.supp:print_suppressions=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
(cd "$asan_dir" && ctest --output-on-failure -j2 --timeout 1800)
