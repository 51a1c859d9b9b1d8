#!/usr/bin/env bash
# Slurm job array: one task per shard, the same binary everywhere. Each task reads its shard from
# SLURM_ARRAY_TASK_ID and the total from SLURM_ARRAY_TASK_COUNT (--shard auto). A failed or
# preempted task can simply be resubmitted: it resumes in the same folder.
#
#   jobid=$(sbatch --parsable deploy/slurm-synth.sh synth.toml /scratch/faces)
#   sbatch --dependency=afterok:$jobid --wrap "facesynth synth merge /scratch/faces"
#
#SBATCH --job-name=facesynth-synth
#SBATCH --array=0-15
#SBATCH --cpus-per-task=4
#SBATCH --mem=4G
#SBATCH --time=04:00:00
#SBATCH --requeue
set -euo pipefail

config=${1:?usage: sbatch slurm-synth.sh CONFIG.toml OUT_DIR}
out=${2:?usage: sbatch slurm-synth.sh CONFIG.toml OUT_DIR}

exec facesynth synth --config "$config" --out "$out" --shard auto --threads "${SLURM_CPUS_PER_TASK:-1}" --quiet
