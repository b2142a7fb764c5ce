#!/usr/bin/env bash
# A landmark search (`host-sim optimize`) run as Slurm job arrays: each generation's
# missing evaluations are split over TASKS array tasks; between generations the driver
# (this script, on the login node) merges the shards and advances the GA. The result is the
# local run's with the same settings, bit for bit: every evaluation is a pure function of
# (genome, scenario, seed) and the GA's draws depend only on the seed.
#
#   scripts/slurm/optimize-on-slurm.sh DIR TASKS [optimize flags: --model p1 --seed 7 ...]
#
# DIR must be on a file system the compute nodes share. Continue an interrupted study with
# the same command without flags (DIR holds them). Environment: HOST_SIM (the binary,
# default target/release/host-sim), SBATCH_FLAGS (extra sbatch flags: partition, account).
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: $0 DIR TASKS [host-sim optimize flags]" >&2
  exit 2
fi
dir=$1
tasks=$2
shift 2
here=$(cd "$(dirname "$0")" && pwd)
host_sim=$(realpath "${HOST_SIM:-$here/../../target/release/host-sim}")
[ -x "$host_sim" ] || { echo "no host-sim at $host_sim: cargo build --release -p host-sim" >&2; exit 2; }
mkdir -p "$(dirname "$dir")"
dir=$(realpath -m "$dir")

if [ -f "$dir/search.json" ]; then
  # A pending generation left by an interrupted driver: merge what its tasks finished.
  if [ -f "$dir/pending.csv" ] && [ -d "$dir/shards" ]; then
    "$host_sim" optimize --resume "$dir" --merge || true
  fi
  "$host_sim" optimize --resume "$dir" --pending-only --quiet
else
  "$host_sim" optimize --out "$dir" --pending-only --quiet "$@"
fi

generation=0
while [ -f "$dir/pending.csv" ]; do
  generation=$((generation + 1))
  pending=$(($(wc -l < "$dir/pending.csv") - 1))
  n=$(( pending < tasks ? pending : tasks ))
  echo "step $generation: $pending evaluations over $n array tasks"
  # shellcheck disable=SC2086
  sbatch --wait --quiet --array="0-$((n - 1))" --chdir="$dir" ${SBATCH_FLAGS:-} \
    "$here/evaluate-shard.sbatch" "$host_sim" "$dir"
  "$host_sim" optimize --resume "$dir" --merge
  "$host_sim" optimize --resume "$dir" --pending-only --quiet
done
echo "search finished: $dir/summary.json, $dir/report.html"
