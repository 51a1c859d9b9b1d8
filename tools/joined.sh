#!/usr/bin/env bash
# Trains the joined regressor for real photographs (docs/results.md, "Face profiling", "The three joined"):
# three SDMs trained on different data from one folder of annotated photographs, joined by `train merge`
# into one model whose landmarks are the members' average (read it as realign:MODEL):
#   1. renders       tools/sim2real.sh --renders-only: the sim-to-real recipe's renders (COUNT, default 6000,
#                    seed 101) with a texture bank from the photographs
#   2. profiled      facesynth profile: 8 views per photograph turned up to 60° toward profile, pitch jitter 5°
#   3. members       facesynth train, each with a 4-stage realigned cascade and 6 stages:
#                    photographs.sdm     the photographs alone, each with 3 moved and degraded copies
#                                        (--image-copies 3), 10 starts per image
#                    mix.sdm             the renders + the photographs listed 5 times (4 starts per face)
#                    mix_profiled.sdm    the renders + the profiled views + the photographs 5 times (4 starts)
#   4. facesynth train merge   the three into OUT
# With helen_train (870 photographs) and the defaults on 2 cores: 2 h 41 min of CPU time, 85 min wall with
# nothing beside it, 6.4 GB at most (docs/history/results-runs.md, forty-seventh run).
# usage: tools/joined.sh --photos DIR --out MODEL.sdm [--work DIR] [--count N] [--threads T]
#                        [--hog-cells C]  (HOG cells per patch side of every member, default 3)
set -euo pipefail
photos="" out="" work="" count=6000 threads=2 hog_cells=3
while [[ $# -gt 0 ]]; do
    case $1 in
        --photos) photos=$2; shift 2 ;;
        --out) out=$2; shift 2 ;;
        --work) work=$2; shift 2 ;;
        --count) count=$2; shift 2 ;;
        --threads) threads=$2; shift 2 ;;
        --hog-cells) hog_cells=$2; shift 2 ;;
        -h|--help) awk 'NR > 1 && !/^#/ { exit } NR > 1' "$0"; exit 0 ;;
        *) echo "joined: unknown argument '$1' (see --help)" >&2; exit 2 ;;
    esac
done
[[ -n $photos && -n $out ]] || { echo "joined: --photos DIR and --out MODEL are required (see --help)" >&2; exit 2; }
[[ $count =~ ^[1-9][0-9]*$ && $threads =~ ^[1-9][0-9]*$ && $hog_cells =~ ^[1-8]$ ]] ||
    { echo "joined: --count and --threads take whole numbers, --hog-cells 1-8" >&2; exit 2; }
[[ -d $photos ]] || { echo "joined: $photos: photo folder not found" >&2; exit 1; }
absolute() { [[ $1 == /* ]] && echo "$1" || echo "$PWD/$1"; }
photos=$(absolute "$photos")
out=$(absolute "$out")
work=$(absolute "${work:-$(dirname "$out")/joined-work}")
[[ ${FACESYNTH:-} != */* ]] || FACESYNTH=$(absolute "$FACESYNTH")
cd "$(dirname "$0")/.."
facesynth=${FACESYNTH:-build/facesynth}
[[ -x $facesynth ]] || { echo "joined: $facesynth not found: build first (README) or set FACESYNTH" >&2; exit 1; }
export FACESYNTH=$facesynth
mkdir -p "$work"
quiet=()
[[ -t 2 ]] || quiet=(--quiet)

tools/sim2real.sh --photos "$photos" --renders-only --work "$work/sim2real" --count "$count" --seeds 101 --threads "$threads"
renders=$work/sim2real/seed-101/train
"$facesynth" profile --photos "$photos" --out "$work/profiled" --overwrite --views-per-photo 8 --yaw-limit 60 --pitch-jitter 5 --seed 1 \
    --threads "$threads" "${quiet[@]}"
train=(--hog-cells "$hog_cells" --stages 6 --threads "$threads" --lambda-factors 3,10,30,100 --realign-stages 4 "${quiet[@]}")
p=$photos
"$facesynth" train --data "$p" --out "$work/photographs.sdm" --augment 10 --image-copies 3 "${train[@]}" --json "$work/photographs.json"
"$facesynth" train --data "$renders,$p,$p,$p,$p,$p" --out "$work/mix.sdm" --augment 4 "${train[@]}" --json "$work/mix.json"
"$facesynth" train --data "$renders,$work/profiled,$p,$p,$p,$p,$p" --out "$work/mix_profiled.sdm" --augment 4 "${train[@]}" \
    --json "$work/mix_profiled.json"
"$facesynth" train merge "$work/photographs.sdm" "$work/mix.sdm" "$work/mix_profiled.sdm" --out "$out" "${quiet[@]}"
echo "joined: $out (read it as realign:$out; work files in $work)"
