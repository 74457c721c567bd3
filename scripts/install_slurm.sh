#!/usr/bin/env bash
# A single-node SLURM cluster on this machine, from Debian's packages, for docs/cluster.md's
# batch script (tests/test_slurm.py): slurmctld, slurmd, slurm-client and munge installed
# (about 25 s; nothing when present), /etc/slurm/slurm.conf written for this host with 2 CPUs,
# then munged, slurmctld and slurmd started unless they answer already. Exits 0 once the node
# takes jobs; when present and running it only checks (well under a second).
#
# Containers often have no writable cgroups, so the configuration uses no cgroup plugin:
# proctrack/linuxproc, task/none, no accounting. A slurm.conf that this script did not write
# is never replaced: the script stops and names it.
#
#   install_slurm.sh           install, configure, start
#   install_slurm.sh --stop    stop the daemons this configuration starts (pid files)
set -euo pipefail
name=install_slurm
conf=/etc/slurm/slurm.conf
marker="# written by whale-adapter scripts/install_slurm.sh"
say() { echo "$name: $*"; }
die() { echo "$name: $*" >&2; exit 1; }

pids=(/run/slurmd.pid /run/slurmctld.pid /run/munge/munged.pid)
if [ "${1:-}" = "--stop" ]; then
    for f in "${pids[@]}"; do
        [ -f "$f" ] && kill "$(cat "$f")" 2>/dev/null && say "stopped $(basename "$f" .pid)"
    done
    exit 0
fi

bash "$(dirname "$0")/apt_ensure.sh" "$name" slurmctld slurmd slurm-client munge
need_root() { [ "$(id -u)" -eq 0 ] || die "need root to $*"; }   # only for what is not done yet

# --- slurm.conf --------------------------------------------------------------------------
host=$(hostname -s)
want=$(cat <<EOF
$marker
# A one-node test cluster: root's daemons, no cgroups, no accounting.
ClusterName=whale
SlurmctldHost=$host
SlurmUser=root
AuthType=auth/munge
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
NodeName=$host CPUs=2 State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
)
if [ -f "$conf" ] && ! grep -qxF "$marker" "$conf"; then
    die "$conf exists and was not written by this script; left as it is"
fi
if [ "$(cat "$conf" 2>/dev/null)" != "$want" ]; then
    need_root "write $conf"
    mkdir -p /var/spool/slurmctld /var/spool/slurmd /var/log/slurm
    printf '%s\n' "$want" > "$conf"
    say "wrote $conf (node $host, 2 CPUs)"
    changed=1
fi

# --- daemons -----------------------------------------------------------------------------
# running: its pid file names a process that is not a zombie (readable without root)
alive() { [ -f "$1" ] && [ -r "/proc/$(cat "$1")/status" ] && ! grep -q "^State:.*Z" "/proc/$(cat "$1")/status"; }
if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
    need_root "start munged"
    install -d -o munge -g munge -m 0755 /run/munge
    runuser -u munge -- /usr/sbin/munged || die "munged did not start (/var/log/munge/munged.log)"
    say "started munged"
fi
if [ -n "${changed:-}" ]; then   # a new configuration: restart what runs with the old one
    for f in /run/slurmd.pid /run/slurmctld.pid; do alive "$f" && kill "$(cat "$f")" && sleep 1; done
fi
alive /run/slurmctld.pid || { need_root "start slurmctld"; slurmctld || die "slurmctld did not start (/var/log/slurm/slurmctld.log)"; say "started slurmctld"; }
alive /run/slurmd.pid || { need_root "start slurmd"; slurmd || die "slurmd did not start (/var/log/slurm/slurmd.log)"; say "started slurmd"; }

# --- the node takes jobs -----------------------------------------------------------------
for _ in $(seq 1 60); do
    state=$(sinfo -h -n "$host" -o %T 2>/dev/null || true)
    case "$state" in
        idle*|mixed*|allocated*|completing*) exit 0 ;;
        down*|drain*) scontrol update nodename="$host" state=resume 2>/dev/null || true ;;
    esac
    sleep 0.5
done
die "node $host is not up (sinfo: ${state:-no answer}); see /var/log/slurm/slurmd.log and slurmctld.log"
