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
#
# Batches: clang-tidy spends most of its time parsing the headers a file includes (Eigen, OpenCV, the
# standard library), so files of one target are checked FACESYNTH_TIDY_BATCH (default 8; 1 = one by one)
# at a time through a file that includes them all, with the target's compile command and a header
# filter that also reports in the included .cpp files. A batch that does not pass (a finding, or two
# files that cannot share a translation unit) is checked again file by file, so findings are always
# reported against their own file. Files with main() and files outside the compile database are
# checked alone.
#
# Result cache (like ccache's direct mode): a file that passed is not checked again while the
# clang-tidy binary, every .clang-tidy, its compile command and every file it read (the includes
# clang-tidy itself listed, system headers too) are byte-identical, since clang-tidy would then
# print the same. Only passes are kept; a file with findings is checked every time.
# FACESYNTH_TIDY_CACHE sets the folder (default ~/.cache/facesynth-tidy); FACESYNTH_TIDY_CACHE=off
# checks every file afresh.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${FACESYNTH_BUILD_DIR:-build}
# Configuring writes the generated headers (the compiled-in completion table) that clang-tidy parses.
[[ -f $build_dir/compile_commands.json ]] || cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
if [[ $# -gt 0 ]]; then
    files=("$@")
elif git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
    mapfile -t files < <(git ls-files --cached --others --exclude-standard '*.cpp' ':!:tests/**')
else
    mapfile -t files < <(find core degrade morph render synth fit frontal recognition train profile report track tools examples bench fuzz -name '*.cpp' 2>/dev/null | sort)
fi
jobs=${FACESYNTH_TIDY_JOBS:-2}

export TIDY_ROOT=$PWD TIDY_BUILD=$build_dir
# tests/ is on the include path for fuzz/make_seeds.cpp, which reuses the tests' model writers.
export TIDY_EXTRA=-I$PWD/tests
export TIDY_CACHE=${FACESYNTH_TIDY_CACHE:-${XDG_CACHE_HOME:-${HOME:-/tmp}/.cache}/facesynth-tidy}
[[ $TIDY_CACHE == off ]] && TIDY_CACHE=
tidy_one() {
    local file=$1 db_dir=${2:-$TIDY_BUILD} filter=()
    [[ $db_dir == "$TIDY_BUILD" ]] || filter=(--header-filter="$TIDY_BATCH_FILTER")
    if [[ -z $TIDY_CACHE ]]; then
        clang-tidy -p "$db_dir" --quiet "${filter[@]}" --extra-arg="$TIDY_EXTRA" "$file"
        return
    fi
    local abs rel key manifest deps rc=0
    abs=$(realpath -m "$file")
    rel=${abs#"$TIDY_ROOT"/}
    # The file's compile command with the checkout's folder taken out (a clone elsewhere hits too);
    # a file missing from the database gets the flags of another, so then the whole database counts.
    local db=$db_dir/compile_commands.json cmd
    cmd=$(awk -v f="$abs" -F'"command": ' '/"command": /{c=$2} index($0, "\"file\": \"" f "\""){print c; n++} END{if(!n) print "missing"}' "$db")
    key=$( { printf '%s\n%s\n%s\n' "$TIDY_SALT" "$rel" "$cmd"; if [[ $cmd == missing ]]; then cat "$db"; fi; } |
           sed "s|$TIDY_ROOT|.|g" | sha256sum | cut -c1-64)
    manifest=$TIDY_CACHE/$key
    if [[ -f $manifest ]] && (cd "$TIDY_ROOT" && sha256sum --check --status "$manifest" 2>/dev/null); then
        touch "$manifest"
        return 0
    fi
    deps=$(mktemp)
    clang-tidy -p "$db_dir" --quiet "${filter[@]}" --extra-arg="$TIDY_EXTRA" --extra-arg=-Wp,-MD,"$deps" "$file" || rc=$?
    if [[ $rc == 0 && -s $deps ]]; then
        # Make's dependency syntax -> one path a line (relative inside the checkout) -> sha256sum lines.
        sed -e 's/^[^:]*://' -e 's/\\$//' "$deps" | tr ' ' '\n' | sed '/^$/d' | sed "s|^$TIDY_ROOT/||" | sort -u |
            (cd "$TIDY_ROOT" && xargs -d '\n' sha256sum) > "$manifest.$$" && mv "$manifest.$$" "$manifest"
    fi
    rm -f "$deps" "$manifest.$$"
    return $rc
}
if [[ -n $TIDY_CACHE ]]; then
    mkdir -p "$TIDY_CACHE"
    find "$TIDY_CACHE" -type f -mtime +30 -delete  # entries unused for a month
    TIDY_SALT=$( { sha256sum "$(readlink -f "$(command -v clang-tidy)")" | cut -c1-64
                   git ls-files -z '*.clang-tidy' 2>/dev/null | xargs -0 -r cat; cat .clang-tidy; echo "$TIDY_EXTRA"
                 } | sed "s|$TIDY_ROOT|.|g" | sha256sum | cut -c1-64)
    export TIDY_SALT
fi
# A batch (a file including its members) passes, or its members are checked one by one.
tidy_batch() {
    local batch=$1
    if [[ $batch != */tidy-batches/* ]]; then
        tidy_one "$batch"
        return
    fi
    tidy_one "$batch" "$TIDY_BATCHES" >/dev/null 2>&1 && return 0
    local rc=0 member
    while read -r member; do
        tidy_one "$member" || rc=1
    done < <(sed -n 's/^#include "\([^"]*\)".*/\1/p' "$batch")
    return $rc
}
export -f tidy_one tidy_batch
batch_size=${FACESYNTH_TIDY_BATCH:-8}
export TIDY_BATCHES=$build_dir/tidy-batches
# The project's header filter, widened to the .cpp files a batch includes.
TIDY_BATCH_FILTER=$(sed -n "s/^HeaderFilterRegex: *'\(.*\)'/\1/p" .clang-tidy | sed 's/\\\.h\$$/\\.(h|cpp)$/')
export TIDY_BATCH_FILTER
mapfile -t units < <(python3 - "$build_dir" "$batch_size" "${files[@]}" <<'PY'
import json, os, re, sys
build, size, files = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
out_dir = os.path.join(build, "tidy-batches")
os.makedirs(out_dir, exist_ok=True)
for old in os.listdir(out_dir):
    os.remove(os.path.join(out_dir, old))
commands = {}
with open(os.path.join(build, "compile_commands.json")) as f:
    for entry in json.load(f):
        commands[os.path.realpath(entry["file"])] = entry
groups, single = {}, []
for name in files:
    path = os.path.realpath(name)
    entry = commands.get(path)
    with open(path, errors="replace") as f:
        has_main = re.search(r"\bint\s+main\s*\(", f.read()) is not None
    if size <= 1 or entry is None or has_main:
        single.append(name)
        continue
    # One target's files share their command but for the file's own names.
    flags = entry["command"].replace(entry["file"], "@").split(" -o ")[0]
    groups.setdefault((os.path.dirname(path), flags), []).append((path, entry))
database = []
for (folder, _), members in sorted(groups.items()):
    for start in range(0, len(members), size):
        chunk = members[start:start + size]
        if len(chunk) == 1:
            single.append(chunk[0][0])
            continue
        batch = os.path.join(os.path.realpath(out_dir), "%s_%d.cpp" % (folder.strip("/").replace("/", "_"), start // size))
        with open(batch, "w") as f:
            f.writelines('#include "%s"  // NOLINT(bugprone-suspicious-include)\n' % path for path, _ in chunk)
        entry = dict(chunk[0][1])
        entry["command"] = entry["command"].replace(entry["file"], batch)
        entry["file"] = batch
        database.append(entry)
with open(os.path.join(out_dir, "compile_commands.json"), "w") as f:
    json.dump(database, f, indent=1)
for name in single + [e["file"] for e in database]:
    print(name)
PY
)
echo "tidy: clang-tidy on ${#files[@]} files in ${#units[@]} units, $jobs at a time${TIDY_CACHE:+ (unchanged files that passed before are skipped: $TIDY_CACHE)}" >&2
printf '%s\n' "${units[@]}" | xargs -d '\n' -P "$jobs" -n 1 bash -c 'tidy_batch "$1"' tidy_batch
