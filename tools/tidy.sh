#!/usr/bin/env bash
# Runs clang-tidy (the checks in .clang-tidy) on facesynth's sources with the compile commands of
# a CMake build (build/ by default; FACESYNTH_BUILD_DIR picks another; configured if missing).
#   tools/tidy.sh              every .cpp of the project except the tests (tests/): the libraries,
#                              the CLI, the benchmarks and the fuzz harnesses
#   tools/tidy.sh FILE.cpp…    only these
# The fuzz harnesses are not in a gcc build's compile database; clang-tidy then takes the flags of
# the nearest file that is (same include paths), which is all they need.
# FACESYNTH_TIDY_JOBS sets the parallel clang-tidy processes (default 2).
# Exits non-zero when any check fires (WarningsAsErrors).
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${FACESYNTH_BUILD_DIR:-build}
[[ -f $build_dir/compile_commands.json ]] || cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
# Generated headers (the compiled-in completion table) must exist before clang-tidy parses.
cmake --build "$build_dir" -j2 --target facesynth_morph >/dev/null
if [[ $# -gt 0 ]]; then
    files=("$@")
elif git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
    mapfile -t files < <(git ls-files --cached --others --exclude-standard '*.cpp' ':!:tests/**')
else
    mapfile -t files < <(find morph render synth fit train report tools bench fuzz -name '*.cpp' 2>/dev/null | sort)
fi
jobs=${FACESYNTH_TIDY_JOBS:-2}
echo "tidy: clang-tidy on ${#files[@]} files, $jobs at a time" >&2
# tests/ is on the include path for fuzz/make_seeds.cpp, which reuses the tests' model writers.
printf '%s\n' "${files[@]}" | xargs -P "$jobs" -n 1 clang-tidy -p "$build_dir" --quiet --extra-arg=-I"$PWD/tests"
