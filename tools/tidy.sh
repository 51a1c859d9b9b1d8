#!/usr/bin/env bash
# Runs clang-tidy (the checks in .clang-tidy) on facesynth's sources with the compile commands of
# a CMake build (build/ by default; FACESYNTH_BUILD_DIR picks another; configured if missing).
#   tools/tidy.sh              every .cpp of the libraries, the CLI and the fuzz harnesses
#   tools/tidy.sh FILE.cpp…    only these
# Exits non-zero when any check fires (WarningsAsErrors).
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${FACESYNTH_BUILD_DIR:-build}
[[ -f $build_dir/compile_commands.json ]] || cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
# Generated headers (the compiled-in completion table) must exist before clang-tidy parses.
cmake --build "$build_dir" -j2 --target facesynth_morph >/dev/null
if [[ $# -gt 0 ]]; then
    files=("$@")
else
    mapfile -t files < <(ls morph/*.cpp render/*.cpp synth/*.cpp fit/*.cpp train/*.cpp tools/*.cpp 2>/dev/null)
fi
jobs=${FACESYNTH_TIDY_JOBS:-2}
printf '%s\n' "${files[@]}" | xargs -P "$jobs" -n 1 clang-tidy -p "$build_dir" --quiet
