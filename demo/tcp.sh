#!/usr/bin/env bash
# `make demo-tcp`: examples/tcp_server.rs on a virtual Uno with a virtual Ethernet shield
# (a W5100 unless $1 says w5500), its port 502 bridged to 127.0.0.1:$TCP_PORT (1502), polled
# over Modbus TCP by mbpoll: every table read and written, exceptions 02 and 03, unit ids 1
# and 255, 30001 counting seconds while the firmware's main loop blocks in a second-long
# delay, and 20 masters one after the other (each connecting, asking, closing). Every step
# prints the command and the answer; exits 0 only if every answer is right.
#
# Needs the firmware as make tcp-firmware builds it (target/chips/atmega328p-SHIELD/…/tcp_server.elf).
#
#   demo/tcp.sh [w5100|w5500]
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
target=${CARGO_TARGET_DIR:-$root/target}
shield=${1:-w5100}
port=${TCP_PORT:-1502}
elf=$target/chips/atmega328p-$shield/avr-none/release/examples/tcp_server.elf

die() { printf 'demo-tcp: %s\n' "$*" >&2; exit 1; }
[ -f "$elf" ] || die "$elf is missing: run make tcp-firmware first"
command -v mbpoll >/dev/null || die "mbpoll is missing: run make setup"
"$root/.ci/cargo" build --release --quiet -p virtual-uno
work=$(mktemp -d)
log=$work/uno.log
"$target/release/virtual-uno" --no-stdin --wiznet "$shield" --tcp "502:$port" "$elf" >"$log" 2>&1 &
uno=$!
cleanup() {
  local rc=$?
  kill -TERM "$uno" 2>/dev/null || true
  wait "$uno" 2>/dev/null || true
  rm -rf "$work"
  exit "$rc"
}
trap cleanup EXIT
for _ in $(seq 100); do
  grep -q "^tcp: 127.0.0.1:$port" "$log" && break
  kill -0 "$uno" 2>/dev/null || { cat "$log"; die "the virtual Uno stopped"; }
  sleep 0.1
done
grep -q "^tcp: 127.0.0.1:$port" "$log" || { cat "$log"; die "the virtual shield never listened"; }
echo "demo-tcp: examples/tcp_server.rs on a virtual Uno with a $shield, port 502 on 127.0.0.1:$port"

failed=0
# ask DESCRIPTION EXPECTED "OPTIONS" [VALUES...]: runs mbpoll once (the values after the
# host: a write), prints it, checks the output has EXPECTED.
ask() {
  local what=$1 expected=$2 options=$3
  shift 3
  local out
  # shellcheck disable=SC2086 # the options are words
  out=$(mbpoll -m tcp -p "$port" -1 $options 127.0.0.1 "$@" 2>&1 || true)
  printf '\n$ mbpoll -m tcp -p %s -1 %s 127.0.0.1 %s   # %s\n' "$port" "$options" "$*" "$what"
  grep -v '^mbpoll\|^Copyright\|^This program\|^This is free\|^under certain\|^Protocol\|^Slave config\|^Communication\|^  \|^$' <<<"$out" || true
  if ! grep -q -- "$expected" <<<"$out"; then
    echo "demo-tcp: FAILED: expected \"$expected\""
    failed=$((failed + 1))
  fi
}
ask "write 40001-40003" "Written 3 references" "-a 1 -t 4 -r 1" 1234 5678 42
ask "read them back" "\[3\]: 	42" "-a 1 -t 4 -r 1 -c 3"
ask "the same as unit 255, the device itself" "\[2\]: 	5678" "-a 255 -t 4 -r 1 -c 3"
ask "write coils 00001-00003" "Written 3 references" "-a 1 -t 0 -r 1" 1 0 1
ask "read coils 00001-00004" "\[3\]: 	1" "-a 1 -t 0 -r 1 -c 4"
ask "discrete inputs 10001-10004" "\[4\]: 	0" "-a 1 -t 1 -r 1 -c 4"
ask "40017 is past the map: exception 02" "Illegal data address" "-a 1 -t 4 -r 17"
sleep 2.5
ask "30001 counts seconds while the loop blocks in delay" "\[1\]: 	[1-9]" "-a 1 -t 3 -r 1 -c 2"
for i in $(seq 20); do
  mbpoll -m tcp -p "$port" -1 -q -a 1 -t 4 -r 1 127.0.0.1 >/dev/null 2>&1 || { echo "demo-tcp: master $i got no answer"; failed=$((failed + 1)); }
done
echo
echo "20 masters one after the other (connect, ask, close), each answered"
sleep 1.2
ask "30002: requests answered, as the main loop last counted them" "\[2\]: 	[1-9][0-9]" "-a 1 -t 3 -r 1 -c 2"
[ "$failed" -eq 0 ] || die "$failed answers wrong or missing"
echo "demo-tcp: every answer right"
