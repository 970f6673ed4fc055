#!/usr/bin/env bash
# `make demo`: a virtual Uno (simavr on a pseudo-terminal, its optiboot bootloader started at
# every reset) is flashed as a real one is, with `cargo run --release` in demo/uno, an avr-hal
# template project: ravedude -> avrdude -> the bootloader, through the port. Then mbpoll polls
# examples/uno_slave.rs on it, one step per function code, closing a switch and turning a
# potentiometer on the way. `make demo BOARD=mega2560`: a virtual Mega 2560 with its
# stk500v2 bootloader, flashed from demo/mega2560. Prints a transcript; exits 0 only if
# the flash was verified and every answer is the expected one. Needs `make setup` (ravedude,
# avrdude, the bootloaders: make bootloaders) and mbpoll.
#
#   demo/demo.sh [uno|mega2560]   # the port is /tmp/ttyUNO; DEMO_PORT=... to change it
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
target=${CARGO_TARGET_DIR:-$root/target}
board=${1:-uno}
port=${DEMO_PORT:-/tmp/ttyUNO}
case $board in
  uno) chip=atmega328p name="Uno" bootloader=optiboot_atmega328.hex program=uno_slave ;;
  mega2560) chip=atmega2560 name="Mega 2560" bootloader=stk500boot_v2_mega2560.hex program=demo-mega2560 ;;
  *) echo "demo: BOARD=$board? uno or mega2560" >&2; exit 2 ;;
esac
bootloader=$target/bootloaders/$bootloader
# The board's flash and EEPROM, kept from one demo to the next as a board keeps them.
state=$target/boards/$board

die() { printf 'demo: %s\n' "$*" >&2; exit 1; }
[ -f "$bootloader" ] || die "$bootloader is missing: run make bootloaders first"
command -v mbpoll >/dev/null || die "mbpoll is missing (apt-get install mbpoll)"
"$root/.ci/cargo" build --release --quiet -p virtual-uno
bin=$target/release/virtual-uno
started=$(date +%s.%N)

work=$(mktemp -d)
log=$work/virtual-uno.log
control=$work/control
"$bin" --link "$port" --chip "$chip" --bootloader "$bootloader" --state "$state" --control "$control" \
  --no-stdin >"$log" 2>&1 &
uno=$!
trap 'exec 3>&- 2>/dev/null; kill -TERM "$uno" 2>/dev/null; wait "$uno" 2>/dev/null; rm -rf "$work"' EXIT

for _ in $(seq 100); do
  grep -q '^reset: power-on' "$log" && break
  kill -0 "$uno" 2>/dev/null || { cat "$log" >&2; die "the virtual $name did not start"; }
  sleep 0.1
done
grep -q '^reset: power-on' "$log" || { cat "$log" >&2; die "the virtual $name did not start"; }

# since LINE PATTERN: waits up to 5 s for PATTERN in the board's output after line LINE.
since() {
  for _ in $(seq 50); do
    grep -q "$2" <<<"$(tail -n +"$1" "$log")" && return 0
    sleep 0.1
  done
  return 1
}

echo "== a virtual $name ($chip) on $port, its bootloader in the boot section"
sed -n 's/^\(bootloader\|program\|pty\|auto-reset\): /   \1: /p' "$log"
echo "   flash and EEPROM kept in ${state#"$root"/}"

echo
echo "== flashing it as a real $name: cargo run --release in demo/$board"
echo "   $ cd demo/$board && RAVEDUDE_PORT=$port cargo run --release"
mark=$(($(wc -l <"$log") + 1))
flash_start=$(date +%s.%N)
# In the workspace's target directory, its board's -C target-cpu given as make fixtures and
# make chips give it (the flags demo/$board/.cargo/config.toml sets, passed the way that lets
# cargo reuse their build of core rather than compile it again).
flashed=$(cd "$root/demo/$board" && RAVEDUDE_PORT=$port CARGO_TARGET_AVR_NONE_RUSTFLAGS="-C target-cpu=$chip" \
  "$root/.ci/cargo" run --release --quiet --target-dir "$target" 2>&1) \
  || { echo "$flashed"; die "cargo run (ravedude, avrdude) failed"; }
flash_end=$(date +%s.%N)
grep -v '^ *WARN rustc_codegen_ssa\|^$\|TIOCMGET\|^\(Reading\|Writing\) |' <<<"$flashed" | sed 's/^/   /'
grep -q 'bytes of flash verified' <<<"$flashed" || die "avrdude did not verify the flash"
since "$mark" '^serial: 19200 8E1' || { cat "$log" >&2; die "$program did not start after flashing"; }
echo "   [virtual $name]"
tail -n +"$mark" "$log" | grep '^\(reset\|serial\|stopped\): ' | sed 's/^/      /'
printf '   flashed in %.1f s\n' "$(awk "BEGIN { print $flash_end - $flash_start }")"

# A master that opens the port resets the board (DTR), and the bootloader has the line for
# about a second: hold it open for all the polls, as a SCADA or QModMaster does; each mbpoll
# then opens it beside this one without a reset.
echo
echo "== opening the port and keeping it open for the polls: the board resets (DTR),"
echo "   the bootloader waits for avrdude, then starts the program"
mark=$(($(wc -l <"$log") + 1))
opened=$(date +%s.%N)
exec 3<>"$port"
since "$mark" '^reset: RESET' || die "opening the port did not reset the board"
mark=$((mark + $(tail -n +"$mark" "$log" | grep -n -m 1 '^reset: RESET' | cut -d: -f1)))
since "$mark" '^serial: 19200 8E1' || { cat "$log" >&2; die "$program did not start after the reset"; }
ready=$(date +%s.%N)
tail -n +"$((mark - 1))" "$log" | grep '^\(reset\|serial\): ' | sed 's/^/   [virtual '"$name"'] /'
printf '   %s answers %.1f s after the port opened\n' "$program" "$(awk "BEGIN { print $ready - $opened }")"

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
  check "   [virtual Uno] LEDs: " "$1" "$(grep '^pins: ' "$log" | tail -1 | sed 's/^pins: //; s/ (at [0-9.]* s)$//')"
}

echo
echo "== polling $program: each step is one run of mbpoll ${mbpoll_args[*]} ..."

if [ "$board" = uno ]; then
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
else
poll "FC04 Read Input Register 30002 (the chip)" "2560" -t 3 -r 2
poll "FC03 Read Holding Registers 40001-40003" "1234 0 0" -t 4 -r 1 -c 3
poll "FC05 Write Single Coil 00001 = 1" "written 1" -t 0 -r 1 -- 1
poll "FC15 Write Multiple Coils 00006-00008 = 1 0 1" "written 3" -t 0 -r 6 -- 1 0 1
poll "FC01 Read Coils 00001-00008" "1 0 0 0 0 1 0 1" -t 0 -r 1 -c 8
poll "FC02 Read Discrete Inputs 10001-10004" "0 0 0 0" -t 1 -r 1 -c 4
poll "FC06 Write Single Register 40002 = 2025" "written 1" -t 4 -r 2 -- 2025
poll "FC16 Write Multiple Registers 40008-40010 = 7 8 9" "written 3" -t 4 -r 8 -- 7 8 9
poll "FC03 Read Holding Registers 40001-40002" "1234 2025" -t 4 -r 1 -c 2
poll "FC03 Read Holding Registers 40008-40010" "7 8 9" -t 4 -r 8 -c 3
poll "FC17 Report Slave ID, which the slave does not support: exception 01" "Illegal function" -u
poll "FC03 Read Holding Register 40011, which does not exist: exception 02" "Illegal data address" -t 4 -r 11
fi

echo
if [ "$failed" -eq 0 ]; then
  printf '== demo: flashed through the bootloader and all %s steps answered as expected, in %.0f s\n' \
    "$steps" "$(awk "BEGIN { print $(date +%s.%N) - $started }")"
else
  echo "== demo: $failed of $steps steps went wrong; the virtual Uno said:"
  cat "$log"
  exit 1
fi
