# shellcheck shell=bash
# A one-node Slurm cluster on this machine, for testing the job-array search for real
# (sourced by test-slurm.sh, which runs it in a private network namespace):
# `cluster_install` gets Slurm and MUNGE from Debian's packages if missing;
# `cluster_start STATE_DIR` writes a configuration under STATE_DIR (controller and node on
# 127.0.0.1), starts munged, slurmctld and slurmd and exports SLURM_CONF;
# `cluster_stop STATE_DIR` stops them.
#
# slurmctld listens on every interface whatever slurm.conf says (CommunicationParameters=
# NoInAddrAny excludes it), hence the private namespace, where loopback is the only one.
# Needs root for munged and slurmd. No cgroups needed (proctrack/linuxproc, task/none),
# so it runs in a container.

SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"

cluster_install() {
  local need=()
  command -v slurmctld >/dev/null 2>&1 || need+=(slurmctld)
  command -v slurmd >/dev/null 2>&1 || need+=(slurmd)
  command -v sbatch >/dev/null 2>&1 || need+=(slurm-client)
  command -v munged >/dev/null 2>&1 || need+=(munge)
  command -v ip >/dev/null 2>&1 || need+=(iproute2)
  command -v unshare >/dev/null 2>&1 || need+=(util-linux)
  if [ ${#need[@]} -gt 0 ]; then
    echo "slurm: installing ${need[*]} from Debian's packages"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
      "${need[@]}" >/dev/null
  fi
}

cluster_stop() {
  local state=$1
  for pidfile in "$state/slurmd.pid" "$state/slurmctld.pid" "$state/munged.pid"; do
    if [ -f "$pidfile" ]; then
      local pid
      pid=$(cat "$pidfile")
      $SUDO kill "$pid" 2>/dev/null || true
      for _ in $(seq 1 50); do
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.1
      done
      $SUDO kill -9 "$pid" 2>/dev/null || true
      rm -f "$pidfile"
    fi
  done
}

cluster_start() {
  local state=$1
  local conf=$state/slurm.conf
  cluster_stop "$state"
  mkdir -p "$state/ctld" "$state/d" "$state/munge"
  # MUNGE: a key of our own, its socket and logs under target/slurm.
  local key=$state/munge/munge.key
  [ -f "$key" ] || dd if=/dev/urandom of="$key" bs=1024 count=1 status=none
  chmod 0700 "$state/munge"
  chmod 0400 "$key"
  $SUDO munged --force --key-file="$key" --socket="$state/munge/socket" \
    --pid-file="$state/munged.pid" --log-file="$state/munge/munged.log" \
    --seed-file="$state/munge/munged.seed"
  local host cpus
  host=$(hostname -s)
  cpus=$(nproc)
  cat > "$conf" <<CONF
ClusterName=hostsim
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
AuthType=auth/munge
AuthInfo=socket=$state/munge/socket
CredType=cred/munge
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/d
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$state/slurmctld.log
SlurmdLogFile=$state/slurmd.log
SlurmctldPort=6817
SlurmdPort=6818
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MinJobAge=30
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=local Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
  export SLURM_CONF=$conf
  $SUDO env SLURM_CONF="$conf" slurmctld
  $SUDO env SLURM_CONF="$conf" slurmd
  # Wait until the node takes jobs.
  for _ in $(seq 1 20); do
    if timeout 3 sinfo -h -o '%T' 2>/dev/null | grep -qE '^(idle|mixed|allocated)'; then
      echo "slurm: one-node cluster up ($host, $cpus CPUs)"
      return 0
    fi
    sleep 0.5
  done
  echo "slurm: the node did not come up; see $state/slurmctld.log and $state/slurmd.log" >&2
  timeout 3 sinfo >&2 || true
  return 1
}
