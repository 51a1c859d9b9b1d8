#!/usr/bin/env bash
# Builds the libFuzzer harnesses (clang, -DFACESYNTH_FUZZ=ON, in build-fuzz/) and runs one for a
# given time with its seed corpus: valid files made by facesynth's own writers (fuzz/make_seeds.cpp
# and a 2-sample synth run on the toy model), never the licensed data.
#   tools/fuzz.sh NAME SECONDS [extra libFuzzer flags]   e.g. tools/fuzz.sh eos_model 600
#   tools/fuzz.sh --list                                 harness names
#   tools/fuzz.sh --build                                build only
# The growing corpus is kept in build-fuzz/corpus/NAME, findings (crash-*, leak-*, oom-*, timeout-*)
# go to build-fuzz/findings/NAME/. Each finding is fixed and its input kept as a regression test in
# the normal test suite (tests/*/fuzz_regressions or a bad-file test).
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${FACESYNTH_FUZZ_BUILD_DIR:-build-fuzz}
names=$(sed -n 's/^facesynth_fuzzer(\([a-z_]*\) .*/\1/p' fuzz/CMakeLists.txt)

usage() {
    echo "usage: tools/fuzz.sh NAME SECONDS [libFuzzer flags] | --list | --build" >&2
    echo "harnesses: $(echo $names)" >&2
    exit 2
}

build() {
    local launcher=()
    command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
    if [[ ! -f $build_dir/CMakeCache.txt ]]; then
        cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
            -DCMAKE_CXX_COMPILER=clang++ -DFACESYNTH_FUZZ=ON -DFACESYNTH_BUILD_TESTS=OFF \
            -DFACESYNTH_BUILD_BENCH=OFF "${launcher[@]}" >/dev/null
    fi
    cmake --build "$build_dir" -j2 --target "$@"
}

# Seeds are rebuilt when missing (the dataset meta seeds come from a 2-sample synth run).
make_seeds() {
    local seeds=$build_dir/seeds
    [[ -f $seeds/.complete ]] && return
    rm -rf "$seeds"
    ASAN_OPTIONS=detect_leaks=0 "$build_dir/fuzz/fuzz_make_seeds" "$seeds"
    cp data/sfm_landmarks_completion.toml "$seeds/landmark_mapping/"  # the project's own completion table
    touch "$seeds/.complete"
}

[[ $# -ge 1 ]] || usage
case $1 in
    --list) echo "$names"; exit 0 ;;
    --build) build fuzz_make_seeds $(for n in $names; do echo "fuzz_$n"; done); exit 0 ;;
esac
[[ $# -ge 2 ]] || usage
name=$1 seconds=$2
shift 2
grep -qx "$name" <<<"$names" || usage
build "fuzz_$name" fuzz_make_seeds
make_seeds
corpus=$build_dir/corpus/$name findings=$build_dir/findings/$name
mkdir -p "$corpus" "$findings"
# Leaks count as findings (LeakSanitizer with the project's narrow suppressions for Mesa/HDF5).
# An impossible malloc returns NULL as it does outside ASan: HDF5 (C) then reports an error, which
# the reader turns into core::Error; in our C++ code it is std::bad_alloc, still a finding, and
# any allocation over -malloc_limit_mb is reported by libFuzzer before that.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1:intercept_tls_get_addr=0}  # as tools/test.sh
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tools/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
export TMPDIR=${TMPDIR:-/tmp}
exec "$build_dir/fuzz/fuzz_$name" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=256 \
    -print_final_stats=1 -artifact_prefix="$findings/" "$@" "$corpus" "$build_dir/seeds/$name"
