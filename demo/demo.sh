#!/usr/bin/env bash
# `make demo`: runs examples/uno_slave on the virtual Uno and polls it with mbpoll, one step per
# function code, closing a switch and turning a potentiometer on the way. Prints a transcript;
# exits 0 only if every answer is the expected one. Needs `make firmware` and mbpoll.
#
#   demo/demo.sh              # the port is /tmp/ttyUNO; DEMO_PORT=... to change it
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
target=${CARGO_TARGET_DIR:-$root/target}
elf=$target/avr-atmega328p/release/examples/uno_slave.elf
port=${DEMO_PORT:-/tmp/ttyUNO}

die() { printf 'demo: %s\n' "$*" >&2; exit 1; }
[ -f "$elf" ] || die "$elf is missing: run make firmware first"
command -v mbpoll >/dev/null || die "mbpoll is missing (apt-get install mbpoll)"
"$root/.ci/cargo" build --release --quiet -p virtual-uno
bin=$target/release/virtual-uno

work=$(mktemp -d)
log=$work/virtual-uno.log
control=$work/control
"$bin" --link "$port" --control "$control" --no-stdin "$elf" >"$log" 2>&1 &
uno=$!
trap 'kill -TERM "$uno" 2>/dev/null; wait "$uno" 2>/dev/null; rm -rf "$work"' EXIT

for _ in $(seq 100); do
  grep -q '^serial: ' "$log" && break
  kill -0 "$uno" 2>/dev/null || { cat "$log" >&2; die "the virtual Uno did not start"; }
  sleep 0.1
done
grep -q '^serial: ' "$log" || { cat "$log" >&2; die "the firmware did not configure its USART"; }

mbpoll_args=(-m rtu -b 19200 -P even -a 1 -o 1 -1)
steps=0
failed=0

# What mbpoll answered, in one line: the values read, "written N", or its error message.
answer() {
  local out=$1 values
  values=$(sed -n 's/^\[[0-9]*\]:[[:space:]]*//p' <<<"$out" | paste -sd' ')
  if [ -n "$values" ]; then echo "$values"
  elif grep -q '^Written' <<<"$out"; then sed -n 's/^Written \([0-9]*\) references.*/written \1/p' <<<"$out"
  else grep -m1 'failed' <<<"$out" | sed 's/.*failed[^:]*: *//' || echo "no answer"
  fi
}

# check PREFIX EXPECTED GOT
check() {
  steps=$((steps + 1))
  if [ "$3" = "$2" ]; then
    printf '%s%s   ok\n' "$1" "$3"
  else
    printf '%s%s   FAILED (expected %s)\n' "$1" "$3" "$2"
    failed=$((failed + 1))
  fi
}

# poll TITLE EXPECTED MBPOLL-ARGS... [-- VALUES...]
poll() {
  local title=$1 want=$2 out
  shift 2
  printf '\n%s\n   $ mbpoll %s %s\n' "$title" "$*" "$port" | sed "s| -- \(.*\) $port| $port \1|"
  local args=() values=()
  while [ $# -gt 0 ] && [ "$1" != -- ]; do args+=("$1"); shift; done
  [ $# -gt 0 ] && shift && values=("$@")
  out=$(mbpoll "${mbpoll_args[@]}" "${args[@]}" "$port" "${values[@]}" 2>&1) || true
  check "   -> " "$want" "$(answer "$out")"
}

# uno COMMAND WHY: changes an input of the virtual Uno.
uno() {
  printf '\n[virtual Uno] %-12s (%s)\n' "$1" "$2"
  echo "$1" >"$control"
  sleep 0.2
}

# leds EXPECTED: the LED pins the virtual Uno reported last.
leds() {
  sleep 0.2
  check "   [virtual Uno] LEDs: " "$1" "$(grep '^pins: ' "$log" | tail -1 | sed 's/^pins: //')"
}

echo "== the virtual Uno runs uno_slave.elf; its serial port is $port"
sed -n 's/^\(pty\|serial\): /   \1: /p' "$log"
echo "   each step is one run of: mbpoll ${mbpoll_args[*]} ..."

poll "FC01 Read Coils 00001-00005 (LEDs on pins 13, 2, 3, 4, 5)" "0 0 0 0 0" -t 0 -r 1 -c 5
uno "pin 6 0" "close the switch on pin 6"
poll "FC02 Read Discrete Inputs 10001-10004 (switches on pins 6-9)" "1 0 0 0" -t 1 -r 1 -c 4
uno "adc A0 2500" "turn the potentiometer on A0 to 2.5 V"
poll "FC04 Read Input Registers 30001-30003 (A0-A2, 0-1023)" "511 0 0" -t 3 -r 1 -c 3
poll "FC03 Read Holding Registers 40001-40002 (blink period, A0 threshold)" "500 512" -t 4 -r 1 -c 2
poll "FC05 Write Single Coil 00002 = 1 (LED on pin 2)" "written 1" -t 0 -r 2 -- 1
leds "13=off 2=on 3=off 4=off 5=off"
poll "FC15 Write Multiple Coils 00003-00005 = 1 0 1 (LEDs on pins 3-5)" "written 3" -t 0 -r 3 -- 1 0 1
leds "13=off 2=on 3=on 4=off 5=on"
poll "FC01 Read Coils 00001-00005 again" "0 1 1 0 1" -t 0 -r 1 -c 5
poll "FC06 Write Single Register 40003 = 1234" "written 1" -t 4 -r 3 -- 1234
poll "FC16 Write Multiple Registers 40004-40006 = 11 22 33" "written 3" -t 4 -r 4 -- 11 22 33
poll "FC03 Read Holding Registers 40003-40006" "1234 11 22 33" -t 4 -r 3 -c 4
poll "FC17 Report Slave ID, which the slave does not support: exception 01" "Illegal function" -u
poll "FC03 Read Holding Register 40011, which does not exist: exception 02" "Illegal data address" -t 4 -r 11

echo
if [ "$failed" -eq 0 ]; then
  echo "== demo: all $steps steps answered as expected"
else
  echo "== demo: $failed of $steps steps went wrong; the virtual Uno said:"
  cat "$log"
  exit 1
fi
