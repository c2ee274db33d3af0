#!/bin/bash
# Render SCENE in N shards as a Slurm job array, then merge them into OUT.exr.
#   scripts/slurm/submit.sh N SCENE.toml OUT.exr [vitrum render options, e.g. -i path --spp 65536]
# The shards go to OUT.parts/ (part-I-of-N.exr); each task checkpoints and resumes on requeue.
# The merge is cancelled when a task fails (--kill-on-invalid-dep): rerun that task alone
# (sbatch --array=I render-shard.sbatch N ...), then the merge (sbatch merge.sbatch N OUT.parts OUT.exr).
#
# Environment (the jobs get the submitting shell's environment, so these reach them):
#   VITRUM, CHECKPOINT_SECONDS   see render-shard.sbatch.
#   SHARD_SBATCH_OPTIONS         extra sbatch options for the array job, MERGE_SBATCH_OPTIONS for
#                                the merge (whitespace-separated, no quoting), e.g.
#                                SHARD_SBATCH_OPTIONS="--cpus-per-task=32 --partition=long".
#                                Command-line options override the scripts' #SBATCH lines: the
#                                shards ask for 8 CPUs, which a smaller node never grants.
# Slurm's own input variables (SBATCH_PARTITION, SBATCH_ACCOUNT, SBATCH_TIMELIMIT, ...) override
# the #SBATCH lines too, for both jobs (Slurm 22.05 has no SBATCH_CPUS_PER_TASK).
# Prints the two job ids: "submitted: N shards (job array A) and their merge (job M) into OUT.exr".
set -euo pipefail

if [ $# -lt 3 ]; then
    echo "usage: $0 N SCENE.toml OUT.exr [vitrum render options]" >&2
    exit 2
fi
count=$1
scene=$2
out=$3
shift 3
here=$(cd "$(dirname "$0")" && pwd)
parts="${out%.exr}.parts"
read -r -a shard_options <<<"${SHARD_SBATCH_OPTIONS:-}"
read -r -a merge_options <<<"${MERGE_SBATCH_OPTIONS:-}"
# --parsable prints "id" or "id;cluster".
array=$(sbatch --parsable "${shard_options[@]}" --array="0-$((count - 1))" \
    "$here/render-shard.sbatch" "$count" "$scene" "$parts" "$@")
array=${array%%;*}
merge=$(sbatch --parsable "${merge_options[@]}" --dependency="afterok:$array" --kill-on-invalid-dep=yes \
    "$here/merge.sbatch" "$count" "$parts" "$out")
merge=${merge%%;*}
echo "submitted: $count shards (job array $array) and their merge (job $merge) into $out"
