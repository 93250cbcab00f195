#!/usr/bin/env bash
# Single-node Slurm with accounting on Debian 12, for `snakemake --profile workflow/profiles/slurm`.
#   sudo bash workflow/cluster/single_node_slurm.sh          # install, configure, start (safe to re-run)
#   sudo bash workflow/cluster/single_node_slurm.sh --stop   # stop the daemons this script started
# Packages: slurm-wlm slurmdbd munge mariadb-server. Daemons: munged, mariadbd, slurmdbd,
# slurmctld, slurmd; through systemd when it runs, else started directly (containers, VMs).
# One partition, "compute" (the profile's default), with this machine's CPUs (nproc) and
# its memory less max(1 GiB, 10%). Accounting (slurmdbd + MariaDB) is what the
# executor plugin's `sacct` status checks need.
set -euo pipefail

CLUSTER=clothscope
PARTITION=${CLOTHSCOPE_SLURM_PARTITION:-compute} # the profile uses the default partition
ACCOUNT=clothscope
DB=slurm_acct_db
ETC=/etc/slurm
STATE=/run/clothscope-slurm # one marker file per daemon this script started
PACKAGES=(slurm-wlm slurmdbd munge mariadb-server)

die() {
  echo "single_node_slurm.sh: $*" >&2
  exit 1
}
say() { echo "single_node_slurm: $*"; }

case "${1:-}" in
  "" | --start) ACTION=start ;;
  --stop) ACTION=stop ;;
  -h | --help)
    sed -n '2,9p' "$0"
    exit 0
    ;;
  *) die "unknown option '$1' (use --stop, or no option to start)" ;;
esac
[ "$(id -u)" -eq 0 ] || die "must run as root (try: sudo bash $0${1:+ $1})"
command -v apt-get >/dev/null || die "needs Debian's apt-get (this script targets Debian 12)"

# systemd only when it is PID 1; otherwise each daemon is started and stopped by its pid file
if [ -d /run/systemd/system ]; then SYSTEMD=1; else SYSTEMD=0; fi

# --- running / starting / stopping one daemon ---------------------------------------------
pidfile_of() {
  case $1 in
    munge) echo /run/munge/munged.pid ;;
    mariadb) echo /run/mysqld/mysqld.pid ;;
    *) echo "/run/$1.pid" ;;
  esac
}
exe_of() {
  case $1 in
    munge) echo munged ;;
    mariadb) echo mariadbd ;;
    *) echo "$1" ;;
  esac
}
running() { # the pid file names a live (not zombie) process of the right program
  local pid
  pid=$(cat "$(pidfile_of "$1")" 2>/dev/null) || return 1
  [ -n "$pid" ] && [ "$(cat "/proc/$pid/comm" 2>/dev/null)" = "$(exe_of "$1")" ] &&
    [ "$(awk '{print $3}' "/proc/$pid/stat" 2>/dev/null)" != Z ]
}
start_daemon() {
  if [ "$SYSTEMD" = 1 ]; then
    systemctl start "$1"
    return
  fi
  running "$1" && return 0
  case $1 in
    munge)
      install -d -o munge -g munge -m 0755 /run/munge
      runuser -u munge -- /usr/sbin/munged
      ;;
    mariadb)
      install -d -o mysql -g mysql -m 0755 /run/mysqld
      (cd / && setsid -f /usr/bin/mysqld_safe) </dev/null >/dev/null 2>&1
      ;;
    *) "/usr/sbin/$1" ;; # slurm daemons fork into the background themselves
  esac
  mkdir -p "$STATE" && touch "$STATE/$1"
}
stop_daemon() {
  local pid i
  if [ "$SYSTEMD" = 1 ]; then
    systemctl stop "$1"
    return
  fi
  if ! running "$1"; then
    rm -f "$STATE/$1"
    return 0
  fi
  if [ ! -e "$STATE/$1" ]; then
    say "$1 was not started by this script: left running"
    return 0
  fi
  if [ "$1" = mariadb ]; then
    mariadb-admin shutdown
  else
    pid=$(cat "$(pidfile_of "$1")")
    kill -TERM "$pid"
  fi
  for i in $(seq 60); do
    running "$1" || break
    sleep 0.5
  done
  running "$1" && die "$1 did not stop within 30 s"
  rm -f "$STATE/$1"
  say "stopped $1"
}
wait_for() { # wait_for SECONDS WHAT COMMAND...: retry COMMAND until it succeeds
  local seconds=$1 what=$2 i
  shift 2
  for i in $(seq "$seconds"); do
    "$@" >/dev/null 2>&1 && return 0
    sleep 1
  done
  die "$what not ready after ${seconds} s (see /var/log/slurm/ and /var/log/mysql/)"
}

SLURM_DAEMONS=(slurmd slurmctld slurmdbd)
if [ "$ACTION" = stop ]; then
  for d in "${SLURM_DAEMONS[@]}" mariadb munge; do stop_daemon "$d"; done
  exit 0
fi

# --- packages ---------------------------------------------------------------------------------
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  say "installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq "${PACKAGES[@]}" >/dev/null
fi

# --- configuration (files are rewritten only when their content changes) ----------------------
NODE=$(hostname -s)
CPUS=$(nproc)
total_mb=$(awk '/^MemTotal:/ {print int($2 / 1024)}' /proc/meminfo)
headroom_mb=$((total_mb / 10 > 1024 ? total_mb / 10 : 1024))
MEM_MB=$((total_mb - headroom_mb))
[ "$MEM_MB" -ge 1024 ] || die "only ${total_mb} MB of memory: too little for a node (needs > 2 GiB)"
if [ "$SYSTEMD" = 1 ]; then # systemd delegates cgroups to slurmd: let Slurm enforce cores and memory
  TRACKING="ProctrackType=proctrack/cgroup
TaskPlugin=task/cgroup,task/affinity
JobAcctGatherType=jobacct_gather/cgroup"
else # no cgroups of our own: track processes via /proc, kill a job step that exceeds its --mem
  TRACKING="ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/linux
JobAcctGatherParams=OverMemoryKill"
fi

CHANGED=()
put() { # put FILE MODE OWNER: write stdin to FILE if different; remember which file changed
  local tmp
  tmp=$(mktemp)
  cat >"$tmp"
  if cmp -s "$tmp" "$1"; then
    rm -f "$tmp"
  else
    install -m "$2" -o "$3" -g "$3" "$tmp" "$1"
    rm -f "$tmp"
    CHANGED+=("$1")
    say "wrote $1"
  fi
}

mkdir -p "$ETC" /var/log/slurm /var/lib/slurm/slurmctld /var/lib/slurm/slurmd
chown slurm:slurm /var/log/slurm /var/lib/slurm/slurmctld

put "$ETC/slurm.conf" 0644 root <<EOF
# Written by workflow/cluster/single_node_slurm.sh: one node, one partition, with accounting.
ClusterName=$CLUSTER
SlurmctldHost=$NODE(127.0.0.1)
SlurmUser=slurm
AuthType=auth/munge
StateSaveLocation=/var/lib/slurm/slurmctld
SlurmdSpoolDir=/var/lib/slurm/slurmd
SlurmctldPidFile=$(pidfile_of slurmctld)
SlurmdPidFile=$(pidfile_of slurmd)
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
MpiDefault=none
MailProg=/bin/true
ReturnToService=2
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU_Memory
$TRACKING
JobAcctGatherFrequency=task=5
AccountingStorageType=accounting_storage/slurmdbd
AccountingStorageHost=localhost
JobCompType=jobcomp/none
MinJobAge=300
# jobs without --mem get an equal share per CPU instead of the whole node
DefMemPerCPU=$((MEM_MB / CPUS))
NodeName=$NODE NodeAddr=127.0.0.1 CPUs=$CPUS RealMemory=$MEM_MB State=UNKNOWN
PartitionName=$PARTITION Nodes=$NODE Default=YES MaxTime=INFINITE State=UP
EOF

put "$ETC/cgroup.conf" 0644 root <<'EOF'
# Read only when slurm.conf uses the cgroup plugins (hosts where systemd is PID 1).
CgroupPlugin=autodetect
ConstrainCores=yes
ConstrainRAMSpace=yes
ConstrainSwapSpace=yes
AllowedSwapSpace=0
EOF

# slurmdbd's database password: kept from an earlier run, else a new random one
PASS=$(sed -n 's/^StoragePass=//p' "$ETC/slurmdbd.conf" 2>/dev/null || true)
[ -n "$PASS" ] || PASS=$(head -c 24 /dev/urandom | base64 | tr -dc 'A-Za-z0-9')
put "$ETC/slurmdbd.conf" 0600 slurm <<EOF
# Written by workflow/cluster/single_node_slurm.sh
AuthType=auth/munge
DbdHost=localhost
SlurmUser=slurm
PidFile=$(pidfile_of slurmdbd)
LogFile=/var/log/slurm/slurmdbd.log
StorageType=accounting_storage/mysql
StorageHost=localhost
StorageUser=slurm
StoragePass=$PASS
StorageLoc=$DB
EOF

# Slurm's advice for the accounting database; MariaDB listens on localhost only (Debian default)
put /etc/mysql/mariadb.conf.d/60-slurmdbd.cnf 0644 root <<'EOF'
[mysqld]
innodb_lock_wait_timeout = 900
EOF

# --- start, in dependency order (a daemon whose config changed is restarted) -------------------
changed() { [[ " ${CHANGED[*]} " == *" $1 "* ]]; }
if changed /etc/mysql/mariadb.conf.d/60-slurmdbd.cnf && running mariadb; then stop_daemon mariadb; fi
if changed "$ETC/slurmdbd.conf" && running slurmdbd; then stop_daemon slurmdbd; fi
if changed "$ETC/slurm.conf" || changed "$ETC/cgroup.conf"; then
  for d in slurmd slurmctld; do running "$d" && stop_daemon "$d"; done
fi

[ -s /etc/munge/munge.key ] || runuser -u munge -- /usr/sbin/mungekey --create
start_daemon munge
wait_for 20 munge bash -c 'munge -n | unmunge'

start_daemon mariadb
wait_for 60 MariaDB mariadb-admin ping
mariadb <<EOF
CREATE DATABASE IF NOT EXISTS $DB;
CREATE USER IF NOT EXISTS 'slurm'@'localhost' IDENTIFIED BY '$PASS';
ALTER USER 'slurm'@'localhost' IDENTIFIED BY '$PASS';
GRANT ALL PRIVILEGES ON $DB.* TO 'slurm'@'localhost';
EOF

start_daemon slurmdbd
wait_for 60 slurmdbd sacctmgr -n list cluster
# register the cluster, an account, and root (plus the sudo caller) in it
sacctmgr -n -P list cluster format=cluster | grep -qx "$CLUSTER" || sacctmgr -i add cluster "$CLUSTER" >/dev/null
sacctmgr -n -P list account format=account | grep -qx "$ACCOUNT" ||
  sacctmgr -i add account "$ACCOUNT" Cluster="$CLUSTER" Description="clothscope workflow" Organization=clothscope >/dev/null
for u in root ${SUDO_USER:-}; do
  sacctmgr -n -P list user "$u" format=user | grep -qx "$u" ||
    sacctmgr -i add user "$u" Account="$ACCOUNT" DefaultAccount="$ACCOUNT" >/dev/null
done

start_daemon slurmctld
wait_for 30 slurmctld scontrol ping
start_daemon slurmd

# wait for the node to come up idle (a node left down by an unclean stop is resumed)
state=""
for _ in $(seq 60); do
  state=$(sinfo -h -N -n "$NODE" -o %T 2>/dev/null | head -n1 || true)
  case $state in
    idle | mixed | allocated) break ;;
    down* | drain*) scontrol update NodeName="$NODE" State=RESUME 2>/dev/null || true ;;
  esac
  sleep 1
done
case $state in
  idle | mixed | allocated) ;;
  *) die "node $NODE is '${state:-unknown}', not idle, after 60 s (see /var/log/slurm/slurmd.log)" ;;
esac
wait_for 30 sacct sacct -n -X -S now-1hours
say "ready: cluster $CLUSTER, partition $PARTITION, node $NODE ($CPUS CPUs, $MEM_MB MB), state $state"
