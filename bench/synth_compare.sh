#!/usr/bin/env bash
# Alternates `facesynth bench synth` runs of several binaries in the same minutes (VM speed drifts by
# 10 % within half an hour, so A and B must be measured side by side), for each model and with
# LP_NUM_THREADS=0 and unset, and prints one line per run: round, model, LP_NUM_THREADS, binary,
# samples/s with 1 and 2 workers, CPU ms per sample (1, 2 workers), render wall and CPU ms (2 workers).
#   bench/synth_compare.sh BINARY... [-- MODEL...]     (models default: builtin)
# Environment: ROUNDS (3), COUNT (2000), WORK (/dev/shm/facesynth-compare: tmpfs keeps the kernel's
# file creation, which varies with earlier runs' deletions, out of the figure).
set -euo pipefail
binaries=() models=()
while [[ $# -gt 0 && $1 != -- ]]; do binaries+=("$1"); shift; done
[[ $# -gt 0 ]] && shift
models=("$@")
[[ ${#models[@]} -gt 0 ]] || models=(builtin)
[[ ${#binaries[@]} -gt 0 ]] || { echo "usage: $0 BINARY... [-- MODEL...]" >&2; exit 2; }
rounds=${ROUNDS:-3} count=${COUNT:-2000} work=${WORK:-/dev/shm/facesynth-compare}
json=$(mktemp)
trap 'rm -rf "$work" "$json"' EXIT
for round in $(seq "$rounds"); do
    for model in "${models[@]}"; do
        for lp in 0 unset; do
            for binary in "${binaries[@]}"; do
                rm -rf "$work"
                if [[ $lp == unset ]]; then
                    env -u LP_NUM_THREADS "$binary" bench synth -n "$count" --model "$model" --work "$work" --quiet --json "$json" >/dev/null
                else
                    LP_NUM_THREADS=$lp "$binary" bench synth -n "$count" --model "$model" --work "$work" --quiet --json "$json" >/dev/null
                fi
                python3 - "$json" "$round" "$model" "$lp" "$binary" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print(sys.argv[2], sys.argv[3], "LP_NUM_THREADS=" + sys.argv[4], sys.argv[5],
      *(f"{d[k]:.2f}" for k in ("samples_per_s_1_thread", "samples_per_s_all_threads", "cpu_ms_per_sample_1_thread",
                                "cpu_ms_per_sample_all_threads", "ms_render_all_threads", "cpu_ms_render_all_threads")))
PY
            done
        done
    done
done
