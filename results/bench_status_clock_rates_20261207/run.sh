#!/usr/bin/env bash
# usage: run.sh N ARMS...  -- alternate arms, N rounds; prints CPU-s. In the foreground cgroup.
echo $$ > /sys/fs/cgroup/cpu/fic_fore/cgroup.procs
cd /work/main
n=$1; shift
for i in $(seq $n); do
 for arm in "$@"; do
  case $arm in
   A) extra=();;
   S) extra=(--params-file replica=/tmp/ab/replica.yaml);;
   C) extra=(--params-file robot=/tmp/ab/robot.yaml);;
   D) extra=(--params-file channel_forward=/tmp/ab/channel.yaml --params-file channel_backward=/tmp/ab/channel.yaml);;
   SCD) extra=(--params-file replica=/tmp/ab/replica.yaml --params-file robot=/tmp/ab/robot.yaml --params-file channel_forward=/tmp/ab/channel.yaml --params-file channel_backward=/tmp/ab/channel.yaml);;
   T) extra=(--two-stations);;
   O) extra=(--params-file replica=/tmp/ab/replica_old.yaml --params-file robot=/tmp/ab/robot_old.yaml);;
   N) extra=();;
   OT) extra=(--two-stations --params-file replica=/tmp/ab/replica_old.yaml --params-file robot=/tmp/ab/robot_old.yaml);;
   NT) extra=(--two-stations);;
  esac
  /usr/bin/time -f "TIME %U %S %e" -o /tmp/ab/t scripts/run_teleop.sh --no-video "${extra[@]}" > /tmp/ab/log_${arm}_$i 2>&1; rc=$?
  echo "$arm $i rc=$rc $(grep TIME /tmp/ab/t | awk '{print "cpu", $2+$3, "wall", $4}') load=$(cut -d' ' -f1 /proc/loadavg) $(grep -o 'slowest[^,]*' /tmp/ab/log_${arm}_$i | head -1)" >> /tmp/ab/results.txt
 done
done
