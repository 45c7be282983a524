#!/usr/bin/env bash
# Submits a sharded `fipt run` to Slurm as a chain of jobs on a shared folder:
#   bake:  a job array of N tasks, `fipt run --shard K/N` (K = $SLURM_ARRAY_TASK_ID);
#   train: one job, `fipt run --stop-before refine` (merges the shards, trains, stops before
#          the next refinement);
#   then ROUNDS times: the refinement as an array of N tasks, and one job that trains the
#          next round (the last one also runs any settling round, `rounds.settle_rounds`,
#          unsharded, then writes the maps, re-renders and evaluates).
# Each job starts when the one before it succeeded (afterok). Re-submitting the chain is safe:
# finished shards and stages are reused.
#
# Usage: fipt-sharded.sh SCENE OUT [N] [ROUNDS] [-- fipt run options...]
#   N       tasks per array (default 8)
#   ROUNDS  `rounds.refinements` of the run's settings: 1 for fast and balanced (default),
#           2 for paper and reference
# Environment: FIPT (the binary, default `fipt`), SBATCH_ARGS (options for every job, e.g.
#   "--partition=cpu --time=02:00:00 --cpus-per-task=32 --mem=32G"), SBATCH (default sbatch).
# Prints the job id of the last job.
set -euo pipefail

if [[ $# -lt 2 ]]; then
    sed -n '2,18p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
fi
scene=$1 out=$2
shift 2
n=8 rounds=1
if [[ $# -gt 0 && $1 != -- ]]; then n=$1; shift; fi
if [[ $# -gt 0 && $1 != -- ]]; then rounds=$1; shift; fi
if [[ $# -gt 0 && $1 == -- ]]; then shift; fi
if ! [[ $n =~ ^[1-9][0-9]*$ && $rounds =~ ^[0-9]+$ ]]; then
    echo "N must be a positive whole number and ROUNDS a whole number (got N=$n ROUNDS=$rounds)" >&2
    exit 2
fi
fipt=${FIPT:-fipt}
sbatch=${SBATCH:-sbatch}
read -r -a common <<< "${SBATCH_ARGS:-}"

# The command line of one job, quoted for the shell that --wrap starts.
base=$(printf '%q ' "$fipt" run "$scene" --out "$out" "$@")

submit() { # dependency, then sbatch options and --wrap command
    local dep=$1
    shift
    local args=(--parsable "${common[@]}")
    [[ -n $dep ]] && args+=(--dependency="afterok:$dep")
    "$sbatch" "${args[@]}" "$@" | cut -d';' -f1
}

array() { # dependency, job name
    submit "$1" --job-name="$2" --array="0-$((n - 1))" \
        --wrap="$base --shard \$SLURM_ARRAY_TASK_ID/$n"
}

# Every training job but the last stops before the next refinement, which is sharded.
stop() { [[ $1 -lt $rounds ]] && printf ' %s' --stop-before refine || true; }
job=$(array "" fipt-bake)
job=$(submit "$job" --job-name=fipt-train --wrap="$base$(stop 0)")
for ((r = 1; r <= rounds; r++)); do
    job=$(array "$job" "fipt-refine$r")
    job=$(submit "$job" --job-name="fipt-train$r" --wrap="$base$(stop "$r")")
done
echo "$job"
