#!/usr/bin/env bash
# The job-array search tested for real: a one-node Slurm cluster (Debian's slurmctld,
# slurmd, MUNGE) in private network and PID namespaces (loopback only; every daemon ends
# with the test), a small GA run through `sbatch --array` by optimize-on-slurm.sh, the same
# GA run locally, and the two results compared: best genome, fitness, every generation.
# Run by scripts/test-all.sh; needs root (or sudo) and about a minute.
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)
here=$root/scripts/slurm

if [ "${HOST_SIM_SLURM_INSIDE:-}" != 1 ]; then
  # Outside: packages and the binary first (the namespace has no network).
  # shellcheck source=one-node-cluster.sh
  source "$here/one-node-cluster.sh"
  cluster_install
  cargo build --release -q -p host-sim
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  exec $SUDO env HOST_SIM_SLURM_INSIDE=1 PATH="$PATH" \
    unshare --net --pid --fork --mount-proc bash "$0"
fi

ip link set lo up
# Slurm resolves its listening address with AI_ADDRCONFIG, which finds no IPv4 address
# where loopback is the only interface: give the namespace a device of its own (a tap
# with no peer: nothing outside the namespace reaches it).
ip tuntap add dev slurm0 mode tap
ip addr add 169.254.77.1/32 dev slurm0
# shellcheck source=one-node-cluster.sh
source "$here/one-node-cluster.sh"
work=$root/target/slurm-test
rm -rf "$work"
mkdir -p "$work"
state=$work/cluster
trap 'cluster_stop "$state"' EXIT
cluster_start "$state"

flags=(--model p1 --population 12 --generations 4 --length 4 --seed 9 --validation-seeds 3)
t0=$(date +%s)
bash "$here/optimize-on-slurm.sh" "$work/array" 2 "${flags[@]}"
t1=$(date +%s)
"$root/target/release/host-sim" optimize "${flags[@]}" --out "$work/local" --quiet >/dev/null

tasks=$(find "$work/array" -name 'slurm-*_*.out' | wc -l)
# The summaries without what may differ between sessions (wall time, the files' paths).
summary() {
  python3 -c 'import json, sys
s = json.load(open(sys.argv[1]))
for k in ("wall_time_s", "files"):
    s.pop(k, None)
print(json.dumps(s, indent=1, sort_keys=True))' "$1"
}
fail=0
if [ "$tasks" -lt 2 ]; then
  echo "slurm: expected array tasks to have run, found $tasks task logs" >&2
  fail=1
fi
if ! diff <(summary "$work/array/summary.json") <(summary "$work/local/summary.json"); then
  echo "slurm: the array run's summary differs from the local run's" >&2
  fail=1
fi
if ! diff "$work/array/generations.csv" "$work/local/generations.csv"; then
  echo "slurm: the array run's generations differ from the local run's" >&2
  fail=1
fi
if [ "$fail" -eq 0 ]; then
  best=$(python3 -c 'import json, sys
s = json.load(open(sys.argv[1]))
print([g["value"] for g in s["best_genes"]], "fitness", s["best_fitness_mse"])' "$work/array/summary.json")
  echo "slurm: array run ($tasks tasks, $((t1 - t0)) s) equals the local run: best genome $best"
fi
exit "$fail"
