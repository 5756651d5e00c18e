#!/usr/bin/env bash
# A one-node Slurm cluster on 127.0.0.1, brought up and torn down by this test, renders a
# 24-frame rack focus with scripts/farm/slurm-render as 6 array tasks of 4 frames; every frame
# must equal a single-process `dofkit render --frames 1-24` bit for bit. Then one task is
# cancelled (scancel) while it runs, the job is submitted again with --skip-existing, and the
# test checks that no partial or temporary file was left, that the frames already written were
# not rewritten, and that all 24 frames are right.
#
# usage: tests/farm/slurm_cluster_test.sh [path/to/dofkit]   (default build/dofkit)
# Needs root (slurmd), and the Debian packages slurm-wlm and munge, which it installs with
# apt-get when they are missing. Every daemon (munged, slurmctld, slurmd) runs from a temporary
# folder with its own key, socket, ports, state and logs, and is stopped at the end.
# Exit status: 0 passed; 77 skipped (the cluster cannot be brought up here: one line says why);
# anything else failed. Every wait is bounded. DOFKIT_SLURM_TEST_KEEP=1 keeps the folder.
set -uo pipefail
readonly SKIP=77
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
DOFKIT=${1:-$ROOT/build/dofkit}
PY=/usr/bin/python3  # Debian's, with python3-openimageio (scripts/deps)
[ -x "$PY" ] || PY=python3
FRAMES=24 CHUNK=4 TASKS=6
# 320x180 frames, the exact `reference` method with a large blur: a few tenths of a second
# per frame and thread, so that a task can be caught between its frames and cancelled.
SIZE=320x180 FOCUS_M=6 BLUR_PX=60 MAX_COC_PX=80

say() { echo "slurm-test: $*"; }
T=""
finish() {
  local rc=$?
  trap - EXIT
  [ -n "$T" ] && stop_cluster
  if [ -n "$T" ] && [ "${DOFKIT_SLURM_TEST_KEEP:-0}" = 1 ]; then
    say "kept $T"
  elif [ -n "$T" ]; then
    rm -rf "$T"
  fi
  exit "$rc"
}
trap finish EXIT
trap 'exit 1' INT TERM
skip() {
  say "SKIPPED: $*"
  exit "$SKIP"
}
fail() {
  say "FAILED: $*"
  if [ -n "$T" ] && [ -d "$T/log" ]; then
    for f in "$T"/log/*.log "$T"/logs/*.log; do
      [ -f "$f" ] || continue
      echo "---- last lines of $f"
      tail -n 8 "$f"
    done
  fi
  exit 1
}
# wait_for SECONDS WHAT COMMAND...: polls COMMAND every 0.1 s until it succeeds; 1 after SECONDS.
wait_for() {
  local limit=$1 what=$2
  shift 2
  local end=$((SECONDS + limit))
  until "$@" >/dev/null 2>&1; do
    [ "$SECONDS" -lt "$end" ] || {
      say "waited ${limit} s for $what"
      return 1
    }
    sleep 0.1
  done
}
last_line() { [ -f "$1" ] && grep -v '^\s*$' "$1" | tail -n 1; }

# --- what the test needs ---------------------------------------------------------------------
[ -x "$DOFKIT" ] || fail "$DOFKIT: no dofkit binary (build first)"
DOFKIT=$(realpath "$DOFKIT")
[ "$(id -u)" = 0 ] || skip "needs root to run slurmd (CI runs as root)"
need=(sbatch scontrol squeue scancel sinfo slurmctld slurmd munged munge)
missing() {
  local c
  for c in "${need[@]}"; do command -v "$c" >/dev/null || return 0; done
  return 1
}
if missing; then
  command -v apt-get >/dev/null || skip "slurm-wlm and munge are not installed and there is no apt-get"
  say "installing slurm-wlm munge (apt-get)"
  # The packages' scripts would start the system's own daemons; keep them from doing so.
  added_policy=0
  if [ ! -e /usr/sbin/policy-rc.d ]; then
    printf '#!/bin/sh\nexit 101\n' >/usr/sbin/policy-rc.d && chmod +x /usr/sbin/policy-rc.d && added_policy=1
  fi
  export DEBIAN_FRONTEND=noninteractive
  (timeout 300 apt-get update -qq && timeout 600 apt-get install -y -qq --no-install-recommends slurm-wlm munge) \
    >/tmp/dofkit-slurm-apt.log 2>&1
  apt_rc=$?
  [ "$added_policy" = 1 ] && rm -f /usr/sbin/policy-rc.d
  [ "$apt_rc" = 0 ] || skip "apt-get install slurm-wlm munge failed: $(last_line /tmp/dofkit-slurm-apt.log)"
  missing && skip "slurm-wlm and munge installed, but a command is still missing"
fi
"$PY" -c 'import OpenImageIO, numpy' 2>/dev/null || fail "$PY cannot import OpenImageIO and numpy (scripts/deps installs them)"

# --- the cluster --------------------------------------------------------------------------------
T=$(mktemp -d /tmp/dofkit-slurm.XXXXXX) || fail "mktemp"
chmod 711 "$T"
mkdir -p "$T"/{munge,state,spool,log,run,logs,in}
chmod 700 "$T/munge"
export SLURM_CONF=$T/slurm.conf
stop_cluster() {
  # Cancel what is left of our jobs, stop slurmctld and slurmd, then munged; SIGKILL after 15 s.
  if [ -f "$T/run/slurmctld.pid" ]; then
    timeout 10 scancel --quiet --user=root >/dev/null 2>&1
    timeout 10 scontrol shutdown >/dev/null 2>&1
  fi
  local f pid
  for f in slurmd slurmctld munged; do
    [ -f "$T/run/$f.pid" ] || continue
    pid=$(cat "$T/run/$f.pid" 2>/dev/null)
    [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null || continue
    [ "$f" = munged ] && kill "$pid" 2>/dev/null
    if ! wait_for 15 "$f to stop" bash -c "! kill -0 $pid"; then
      say "$f (pid $pid) did not stop: SIGKILL"
      kill -KILL "$pid" 2>/dev/null
    fi
  done
}

dd if=/dev/urandom of="$T/munge/munge.key" bs=1024 count=1 status=none && chmod 400 "$T/munge/munge.key"
munged --force --socket="$T/munge/munge.socket" --key-file="$T/munge/munge.key" --log-file="$T/log/munged.log" \
  --pid-file="$T/run/munged.pid" --seed-file="$T/munge/munged.seed" >"$T/log/munged.out" 2>&1 ||
  skip "munged did not start: $(last_line "$T/log/munged.out")"
wait_for 10 "munge" bash -c "munge -n -S '$T/munge/munge.socket' | unmunge -S '$T/munge/munge.socket'" ||
  skip "munged does not answer: $(last_line "$T/log/munged.log")"

read -r CTLD_PORT SLURMD_PORT < <("$PY" -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*[x.getsockname()[1] for x in s])')
cat >"$SLURM_CONF" <<EOF
# One node of 2 CPUs on 127.0.0.1; everything under $T.
ClusterName=dofkittest
SlurmctldHost=$(hostname -s)(127.0.0.1)
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
AuthType=auth/munge
AuthInfo=socket=$T/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$T/state
SlurmdSpoolDir=$T/spool
SlurmctldPidFile=$T/run/slurmctld.pid
SlurmdPidFile=$T/run/slurmd.pid
SlurmctldLogFile=$T/log/slurmctld.log
SlurmdLogFile=$T/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SlurmdParameters=config_overrides
ReturnToService=2
KillWait=10
MinJobAge=3600
NodeName=dofkitnode NodeAddr=127.0.0.1 CPUs=2 RealMemory=1000 State=UNKNOWN
PartitionName=dofkit Nodes=dofkitnode Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld -f "$SLURM_CONF" >"$T/log/slurmctld.out" 2>&1 ||
  skip "slurmctld did not start: $(last_line "$T/log/slurmctld.out")"
wait_for 30 "slurmctld" bash -c 'timeout 5 scontrol ping | grep -q "is UP"' ||
  skip "slurmctld is not up: $(grep -i 'error\|fatal' "$T/log/slurmctld.log" | tail -n 1)"
slurmd -f "$SLURM_CONF" -N dofkitnode >"$T/log/slurmd.out" 2>&1 ||
  skip "slurmd did not start: $(last_line "$T/log/slurmd.out")"
wait_for 30 "the node" bash -c '[ "$(timeout 5 sinfo -h -n dofkitnode -o %T)" = idle ]' ||
  skip "node dofkitnode is not idle: $(timeout 5 sinfo -h -n dofkitnode -o '%T %E'); $(grep -i 'fatal' "$T/log/slurmd.log" | tail -n 1)"
say "cluster up: slurmctld :$CTLD_PORT, slurmd :$SLURMD_PORT, node dofkitnode (2 CPUs), state in $T"

# --- the frames ---------------------------------------------------------------------------------
# A rack focus over the `ground` scene: frame k's depth is the scene's scaled by
# s_k = 0.5 * 4^((k-1)/23), so that the fixed --focus 6 lies at 12 m of the scene in frame 1 and
# at 3 m in frame 24 (r = K (focus / (s z) - 1) = K ((focus / s) / z - 1)).
"$DOFKIT" scene ground --out "$T/scene" --size "$SIZE" --layers 0 --samples 1 >"$T/log/scene.out" 2>&1 ||
  fail "dofkit scene: $(last_line "$T/log/scene.out")"
"$PY" - "$T/scene" "$T/in" "$FRAMES" <<'EOF' || fail "writing the input frames"
import shutil, sys
import OpenImageIO as oiio
scene, out, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
z = oiio.ImageBuf(scene + "/depth.exr")
for k in range(1, n + 1):
    shutil.copyfile(scene + "/color.exr", "%s/c.%04d.exr" % (out, k))
    scaled = oiio.ImageBufAlgo.mul(z, 0.5 * 4.0 ** ((k - 1) / (n - 1)))
    if not scaled.write("%s/z.%04d.exr" % (out, k)):
        sys.exit(scaled.geterror())
EOF
render_args() {  # RENDER=(the render of the whole range into folder $1)
  RENDER=("$DOFKIT" render --color "$T/in/c.####.exr" --depth "$T/in/z.####.exr" --frames "1-$FRAMES" \
    --focus "$FOCUS_M" --blur-at-infinity "$BLUR_PX" --max-coc "$MAX_COC_PX" --method reference --output "$1/dof.####.exr")
}
mkdir -p "$T/single"
start=$SECONDS
render_args "$T/single"
"${RENDER[@]}" >"$T/log/single.out" 2>&1 || fail "single-process render: $(last_line "$T/log/single.out")"
say "single-process render of $FRAMES frames ($SIZE): $((SECONDS - start)) s"
cmp -s "$T/single/dof.0001.exr" "$T/single/dof.0024.exr" && fail "frames 1 and 24 are the same: no rack focus"

# --- helpers on jobs ----------------------------------------------------------------------------
submit() {  # submit NAME OUTDIR [extra render flags]: prints the job id
  local name=$1 out=$2
  shift 2
  mkdir -p "$out"
  render_args "$out"
  timeout 30 "$ROOT/scripts/farm/slurm-render" --chunk-size "$CHUNK" --log-dir "$T/logs" --job-name "$name" \
    --cpus-per-task 1 -- "${RENDER[@]}" "$@" 2>>"$T/log/submit.out"
}
job_done() { [ -z "$(timeout 5 squeue -h -j "$1" -o %i 2>/dev/null)" ] && timeout 5 scontrol show job "$1" >/dev/null; }
task_states() {  # task_states JOB: "TASK STATE EXITCODE" per array task, sorted by task
  timeout 10 scontrol show job "$1" | awk '
    /ArrayTaskId=/ { for (i = 1; i <= NF; i++) if ($i ~ /^ArrayTaskId=/) { split($i, a, "="); t = a[2] } }
    /JobState=/ { for (i = 1; i <= NF; i++) if ($i ~ /^JobState=/) { split($i, a, "="); s = a[2] } }
    /ExitCode=/ { for (i = 1; i <= NF; i++) if ($i ~ /^ExitCode=/) { split($i, a, "="); print t, s, a[2] } }' | sort -n
}
# compare_all DIR: every frame bit for bit against the single-process render, no other file;
# sets COMPARED to the number of frames compared.
compare_all() {
  local f name n=0
  for ((f = 1; f <= FRAMES; f++)); do
    printf -v name 'dof.%04d.exr' "$f"
    [ -f "$1/$name" ] || fail "$1/$name: missing"
    cmp -s "$1/$name" "$T/single/$name" || fail "$1/$name differs from the single-process render"
    n=$((n + 1))
  done
  local others
  others=$(find "$1" -mindepth 1 ! -name 'dof.????.exr' | head -n 3)
  [ -z "$others" ] && [ "$(find "$1" -mindepth 1 | wc -l)" = "$FRAMES" ] || fail "$1: other files left: $others"
  COMPARED=$n
}

# --- 1. the whole range as 6 array tasks ----------------------------------------------------------
job=$(submit full "$T/full") || fail "slurm-render: $(last_line "$T/log/submit.out")"
say "submitted job $job: $(last_line "$T/log/submit.out" | sed 's/^slurm-render: //')"
start=$SECONDS
wait_for 300 "job $job" job_done "$job" || fail "job $job did not finish"
states=$(task_states "$job")
completed=$(grep -c ' COMPLETED 0:0$' <<<"$states")
[ "$(wc -l <<<"$states")" = "$TASKS" ] && [ "$completed" = "$TASKS" ] || fail "job $job tasks: $(tr '\n' ';' <<<"$states")"
say "job $job: $completed of $TASKS tasks COMPLETED (exit 0) in $((SECONDS - start)) s"
for ((i = 0; i < TASKS; i++)); do
  grep -q "chunk $i of $TASKS (from 0): frames $((CHUNK * i + 1))..$((CHUNK * i + CHUNK)), $CHUNK of the $FRAMES" \
    "$T/logs/full-${job}_$i.log" || fail "task $i's log does not name its frames: $(head -n 3 "$T/logs/full-${job}_$i.log" | tr '\n' ' ')"
done
compare_all "$T/full"
say "$COMPARED frames compared bit for bit with the single-process render: identical"

# --- 2. cancel a task while it runs, then resume with --skip-existing -----------------------------
frames_of() {  # frames of task $1 written in $2
  local f name c=0
  for ((f = CHUNK * $1 + 1; f <= CHUNK * $1 + CHUNK; f++)); do
    printf -v name 'dof.%04d.exr' "$f"
    [ -f "$2/$name" ] && c=$((c + 1))
  done
  echo "$c"
}
job=$(submit cancel "$T/resume") || fail "slurm-render: $(last_line "$T/log/submit.out")"
say "submitted job $job"
cancelled=""
end=$((SECONDS + 300))
while [ -z "$cancelled" ] && [ "$SECONDS" -lt "$end" ] && ! job_done "$job"; do
  # A running task that has written exactly one of its frames: it is between frames 1 and 4.
  for i in $(timeout 5 squeue -h -r -j "$job" -t RUNNING -o %K 2>/dev/null); do
    if [ "$(frames_of "$i" "$T/resume")" = 1 ]; then
      timeout 10 scancel "${job}_$i" && cancelled=$i
      break
    fi
  done
  sleep 0.02
done
[ -n "$cancelled" ] || fail "job $job: no task could be caught between its frames to cancel"
wait_for 300 "job $job" job_done "$job" || fail "job $job did not finish"
states=$(task_states "$job")
grep -q "^$cancelled CANCELLED" <<<"$states" || fail "task $cancelled is not CANCELLED: $(tr '\n' ';' <<<"$states")"
left=$(frames_of "$cancelled" "$T/resume")
[ "$left" -lt "$CHUNK" ] || fail "task $cancelled wrote all its frames: it was not cancelled mid-run"
grep -q "stopped by SIGTERM after" "$T/logs/cancel-${job}_$cancelled.log" ||
  fail "task $cancelled's log has no SIGTERM stop: $(tail -n 2 "$T/logs/cancel-${job}_$cancelled.log" | tr '\n' ' ')"
written=$(find "$T/resume" -mindepth 1 -name 'dof.????.exr' | wc -l)
others=$(find "$T/resume" -mindepth 1 ! -name 'dof.????.exr')
[ -z "$others" ] || fail "files left beside the frames after scancel: $others"
for f in "$T"/resume/dof.????.exr; do
  cmp -s "$f" "$T/single/$(basename "$f")" || fail "$f (written before the cancel) differs from the single-process render"
done
say "job $job: task $cancelled cancelled (scancel) after $left of its $CHUNK frames; $written of $FRAMES frames written, each complete and right, no temporary file left"
inodes_before=$(stat -c '%n %i' "$T"/resume/dof.????.exr)

job=$(submit resume "$T/resume" --skip-existing) || fail "slurm-render: $(last_line "$T/log/submit.out")"
wait_for 300 "job $job" job_done "$job" || fail "job $job did not finish"
states=$(task_states "$job")
completed=$(grep -c ' COMPLETED 0:0$' <<<"$states")
[ "$completed" = "$TASKS" ] || fail "job $job tasks: $(tr '\n' ';' <<<"$states")"
skipped=$(cat "$T"/logs/resume-"${job}"_*.log | sed -n 's/^dofkit: --skip-existing: \([0-9]*\) of.*/\1/p' | awk '{ s += $1 } END { print s + 0 }')
[ "$skipped" = "$written" ] || fail "job $job skipped $skipped frames, $written were already written"
while read -r name inode; do
  [ "$(stat -c %i "$name")" = "$inode" ] || fail "$name was written again although it existed"
done <<<"$inodes_before"
compare_all "$T/resume"
say "job $job (--skip-existing): $completed of $TASKS tasks COMPLETED, $skipped frames skipped and left as they were, $((FRAMES - skipped)) rendered; $COMPARED frames compared bit for bit: identical"
say "PASSED"
