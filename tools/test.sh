#!/usr/bin/env bash
# Builds facesynth and runs the whole test suite twice (README's second command; .ci/run calls it):
#   1. Release, in build/ (FACESYNTH_BUILD_DIR), a unity build, with the Python package's pytest suite (CTest test python);
#   2. clang-tidy over every non-test .cpp (tools/tidy.sh, the checks in .clang-tidy), with the compile
#      commands of a configured (not built) tree without unity, in build-tidy/, eight files of a target at a time;
#   3. AddressSanitizer + UndefinedBehaviorSanitizer with leak detection on, in build-asan/ (unity build)
#      (FACESYNTH_ASAN_BUILD_DIR), without the Python package and the few tests listed below that it cannot
#      add to, each test program run as GoogleTest shards of about 12 cases (CTest names them
#      test_<module>.shard<k>of<n>). tools/lsan.supp suppresses leaks inside Mesa's and HDF5's libraries only.
# --quick skips steps 2 and 3 (for local runs); CI runs all three.
# Compiles through ccache when it is installed (tools/ccache.sh); clang-tidy keeps its own cache of
# files that passed (tools/tidy.sh). Each step prints its wall time.
set -euo pipefail
cd "$(dirname "$0")/.."
full=1
for arg in "$@"; do
    case $arg in
        --quick) full=0 ;;
        -h|--help) sed -n '2,12p' "$0"; exit 0 ;;
        *) echo "usage: tools/test.sh [--quick]" >&2; exit 2 ;;
    esac
done
bash tools/install-deps.sh
source tools/ccache.sh
step_start=$SECONDS
step() { echo "test.sh: $1 took $((SECONDS - step_start)) s" >&2; step_start=$SECONDS; }

build_dir=${FACESYNTH_BUILD_DIR:-build}
# Unity build (eight files per translation unit, as the sanitizer pass and the tests always are): the
# headers (Eigen, OpenCV, CLI11, Ceres) are compiled once per eight files; a plain `cmake -S . -B build`
# still compiles every file on its own.
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_UNITY_BUILD=ON -DCMAKE_UNITY_BUILD_BATCH_SIZE=8 "${cmake_launcher[@]}"
cmake --build "$build_dir" -j2
step "Release build"
(cd "$build_dir" && ctest --output-on-failure -j2 --timeout 900)
step "Release tests"
[[ $full == 1 ]] || exit 0

# clang-tidy checks each .cpp with its own compile command, which a unity build's database lacks (it
# lists the unity files): a configured, unbuilt tree without unity gives them (and the generated headers).
tidy_dir=${FACESYNTH_TIDY_BUILD_DIR:-build-tidy}
cmake -S . -B "$tidy_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
FACESYNTH_BUILD_DIR=$tidy_dir bash tools/tidy.sh
step "clang-tidy"

# Benchmarks are not built in the sanitizer pass: they are never run by the suite. Nor is the Python
# package: an instrumented extension needs the interpreter started with the sanitizer runtime preloaded;
# the C++ it calls (synth::SampleStream) is tested here by GoogleTest, the package in the Release pass. -O1 -g1 instead of
# RelWithDebInfo's -O2 -g: line tables are all that ASan's and UBSan's reports use, and the build
# takes far less CPU. Unity build (eight files per translation unit, as the tests always are): the
# headers (Eigen, OpenCV, CLI11) are compiled once per eight files instead of once per file; the
# Release pass above compiles every file on its own, so each still builds alone (docs/robustness.md).
asan_dir=${FACESYNTH_ASAN_BUILD_DIR:-build-asan}
# Run in the Release pass only: tests whose time goes to code the sanitizers do not instrument (dlib's
# ERT and OpenCV's LBF trainers), or that only repeat, at length, what shorter tests of this pass run
# through the same code (the recipe script's textures, synth and train steps; every command's help).
asan_skip='CmdTrain.ErtAndLbfBaselinesTrainAndEvaluateOnTheSameBoxesAsTheCascade:CmdAppearance.Sim2realRecipeTrainsARegressorOnRendersAlone:CliHabits.EveryCommandHasHelpAndQuietIsAlsoDashQ'
# A sanitizer process takes some 0.5 CPU-s to start (shadow memory, relocating 270 shared libraries
# and a 170 MB executable), so each test program runs as shards of about 12 cases, one process each
# (FACESYNTH_TEST_SHARD_SIZE), not a process per case; executables are linked without PIE, which spares
# the loader the executable's 1.9 million relative relocations at every start of a test program or the CLI.
cmake -S . -B "$asan_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFACESYNTH_SANITIZE=ON -DFACESYNTH_BUILD_BENCH=OFF -DFACESYNTH_PYTHON=OFF \
    -DCMAKE_UNITY_BUILD=ON -DCMAKE_UNITY_BUILD_BATCH_SIZE=8 -DFACESYNTH_TEST_SHARD_SIZE=12 -DFACESYNTH_TEST_EXCLUDE="$asan_skip" \
    -DCMAKE_EXE_LINKER_FLAGS=-no-pie \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" "${cmake_launcher[@]}"
cmake --build "$asan_dir" -j2
step "ASan+UBSan build"
# intercept_tls_get_addr=0: LeakSanitizer misreads the dynamic TLS blocks of libraries loaded with
# dlopen (Mesa's llvmpipe) as an old glibc's and its tracer crashes scanning them (google/sanitizers
# issue 1322; it depends on where the blocks land, so a change anywhere can bring it on). Heap, stacks
# and static TLS are still scanned.
export ASAN_OPTIONS=detect_leaks=1:intercept_tls_get_addr=0
export LSAN_OPTIONS=suppressions=$PWD/tools/lsan.supp:print_suppressions=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
(cd "$asan_dir" && ctest --output-on-failure -j2 --timeout 1800)
step "ASan+UBSan tests"
