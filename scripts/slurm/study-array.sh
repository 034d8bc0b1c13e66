#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# A sweep file's grid on a Slurm cluster (docs/cluster.md): one job array of
# N tasks, task i running `lfi study --sweep FILE --shard i/N` into
# OUT/shards/<i>, and a merge job that runs once every task has succeeded,
# `lfi study merge OUT/sweep OUT/shards/1 ... OUT/shards/N`. The sweep file,
# its bench and OUT must be on a filesystem every node shares; the nodes run
# LFI (default: the lfi on this PATH).
#
#   scripts/slurm/study-array.sh SWEEP_FILE OUT N [sbatch options for both jobs ...]
#
# Prints the array's job id and the merge's. A task replaces its own shard's
# files (--force), so a task that is requeued or run again leaves one shard;
# the merge refuses to replace an earlier merge's OUT/sweep.
set -euo pipefail
if [[ $# -lt 3 ]]; then
  echo "usage: $0 SWEEP_FILE OUT N [sbatch options ...]" >&2
  exit 2
fi
sweep=$1 out=$2 n=$3
shift 3
if [[ ! -r $sweep ]]; then
  echo "study-array: cannot read the sweep file '$sweep'" >&2
  exit 2
fi
if ! [[ $n =~ ^[1-9][0-9]{0,4}$ ]]; then
  echo "study-array: N = '$n' is not a whole number from 1 to 99999" >&2
  exit 2
fi
lfi=${LFI:-$(command -v lfi || true)}
if [[ -z $lfi || ! -x $lfi ]]; then
  echo "study-array: no lfi to run (put it on the PATH or set LFI=/path/to/lfi)" >&2
  exit 2
fi
sweep=$(realpath -e "$sweep") out=$(realpath -m "$out") lfi=$(realpath -e "$lfi")
mkdir -p "$out/shards" "$out/logs"
q() { printf '%q' "$1"; }

array=$(sbatch --parsable --job-name=lfi-sweep --array="1-$n" --requeue --output="$out/logs/shard-%a.log" "$@" \
  --wrap="exec $(q "$lfi") -q study --sweep $(q "$sweep") --out $(q "$out/shards")/\${SLURM_ARRAY_TASK_ID} \
--shard \${SLURM_ARRAY_TASK_ID}/\${SLURM_ARRAY_TASK_COUNT} --force")
array=${array%%;*}  # (--parsable: "id" or "id;cluster")

shards=""
for ((i = 1; i <= n; ++i)); do shards+=" $(q "$out/shards/$i")"; done
merge=$(sbatch --parsable --job-name=lfi-sweep-merge --dependency="afterok:$array" \
  --output="$out/logs/merge.log" "$@" --wrap="exec $(q "$lfi") -q study merge $(q "$out/sweep")$shards")
echo "$array ${merge%%;*}"
