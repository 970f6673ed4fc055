#!/usr/bin/env bash
# `make demo-lab`: the lab bench on one virtual RS-485 line (tools/virtual-uno's
# virtual-line): examples/lab_control.rs as the master (DE on pin 2), examples/lab_lights.rs
# as the button box (device 1) and again as the light tower (device 2, pin 12 jumpered to
# GND), both with DE on pin 10. For about 20 s of wall time, paced to real time as far as
# the CPU allows: waits for the tower's RED, presses START (pin 2 of the box to GND for a
# second), waits for GREEN, presses STOP (pin 3), waits for RED. Prints every frame on the
# line with its sender and the lamps' changes, stamped with the simulated time; exits 0
# only if the lamps followed the buttons and no frame collided or failed its CRC.
#
# Needs the firmware: target/avr-atmega328p/release/examples/lab_control.elf and
# lab_lights.elf (make firmware). Builds virtual-line (release) unless $VIRTUAL_LINE names
# one.
#
#   demo/lab.sh [SECONDS]   # wall time, default 20
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
target=${CARGO_TARGET_DIR:-$root/target}
seconds=${1:-20}
elf=$target/avr-atmega328p/release/examples

die() { printf 'demo-lab: %s\n' "$*" >&2; exit 1; }
for fw in lab_control lab_lights; do
  [ -f "$elf/$fw.elf" ] || die "$elf/$fw.elf is missing: run make firmware first"
done
if [ -z "${VIRTUAL_LINE:-}" ]; then
  "$root/.ci/cargo" build --release --quiet -p virtual-uno --bin virtual-line
  VIRTUAL_LINE=$target/release/virtual-line
fi
[ -x "$VIRTUAL_LINE" ] || die "$VIRTUAL_LINE is missing"

work=$(mktemp -d)
log=$work/line.log
control=$work/control
"$VIRTUAL_LINE" --control "$control" --no-stdin \
  --board "master=$elf/lab_control.elf" de=2 watch=13 \
  --board "box=$elf/lab_lights.elf" de=10 watch=2,3 \
  --board "tower=$elf/lab_lights.elf" de=10 pin12=low watch=4,5,6,7 \
  >"$log" 2>&1 &
line=$!
tail -n +1 -f "$log" &
tailer=$!
cleanup() {
  local rc=$?
  kill -TERM "$line" 2>/dev/null || true
  wait "$line" 2>/dev/null || true
  sleep 0.2
  kill "$tailer" 2>/dev/null || true
  wait "$tailer" 2>/dev/null || true
  rm -rf "$work"
  exit "$rc"
}
trap cleanup EXIT
started=$(date +%s)

# Wall seconds left of the demo.
left() { echo $((started + seconds - $(date +%s))); }

# wait_for PATTERN: waits (while the demo's time lasts) for a line matching PATTERN after
# the last line matched before; sets T to its simulated time.
mark=1
wait_for() {
  while [ "$(left)" -gt 0 ]; do
    kill -0 "$line" 2>/dev/null || return 1
    local found
    found=$(tail -n +"$mark" "$log" | grep -n -m1 -e "$1" || true)
    if [ -n "$found" ]; then
      mark=$((mark + ${found%%:*}))
      T=$(sed 's/^[0-9]*:\[ *\([0-9.]*\)\].*/\1/' <<<"$found")
      return 0
    fi
    sleep 0.1
  done
  return 1
}
# press PIN: the box's button on PIN to GND for a second of wall time, then released.
press() {
  echo "set box pin$1 low" >"$control"
  sleep 1
  echo "set box pin$1 z" >"$control"
}

RED='tower pins: 4=on 5=off 6=off 7=off'
GREEN='tower pins: 4=off 5=on 6=off 7=off'
verdict=()
ok=true
if wait_for "$RED"; then
  verdict+=("RED at start ($T s)")
  sleep 2
  press 2
  t_start='?'
  wait_for 'set: set box pin2 low' && t_start=$T
  if wait_for "$GREEN"; then
    verdict+=("START at $t_start s -> GREEN at $T s")
    sleep 2
    press 3
    t_stop='?'
    wait_for 'set: set box pin3 low' && t_stop=$T
    if wait_for "$RED"; then
      verdict+=("STOP at $t_stop s -> RED at $T s")
    else
      verdict+=("STOP at $t_stop s: the tower did not turn RED"); ok=false
    fi
  else
    verdict+=("START at $t_start s: the tower did not turn GREEN"); ok=false
  fi
else
  verdict+=("the tower never showed RED"); ok=false
fi
# The rest of the demo's time, then the summary.
while [ "$(left)" -gt 0 ] && kill -0 "$line" 2>/dev/null; do sleep 0.2; done
kill -TERM "$line" 2>/dev/null || true
wait "$line" 2>/dev/null || true
sleep 0.3
kill "$tailer" 2>/dev/null || true
wait "$tailer" 2>/dev/null || true

frames=$(grep -c 'frame from' "$log" || true)
bad=$(grep 'frame from' "$log" | grep -c -e 'COLLISION' -e 'bad CRC' -e 'too short' -e 'cut' || true)
echo
echo "== the lab on one virtual RS-485 line: $frames frames"
printf '   %s\n' "${verdict[@]}"
[ "$bad" -eq 0 ] || { echo "   $bad frames collided, were cut or failed their CRC"; ok=false; }
if $ok; then
  echo "== the lights followed the buttons"
else
  echo "== FAILED"
  exit 1
fi
