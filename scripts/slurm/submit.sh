#!/bin/bash
# Render SCENE in N shards as a Slurm job array, then merge them into OUT.exr.
#   scripts/slurm/submit.sh N SCENE.toml OUT.exr [vitrum render options, e.g. -i path --spp 65536]
# The shards go to OUT.parts/ (part-I-of-N.exr); each task checkpoints and resumes on requeue.
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
array=$(sbatch --parsable --array="0-$((count - 1))" "$here/render-shard.sbatch" "$count" "$scene" "$parts" "$@")
array=${array%%;*} # --parsable prints "id" or "id;cluster"
sbatch --dependency="afterok:$array" "$here/merge.sbatch" "$count" "$parts" "$out"
echo "submitted: $count shards (job $array) and their merge into $out"
