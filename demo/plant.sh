#!/usr/bin/env bash
# `make demo-plant`: a whole plant on the virtual network. On one virtual RS-485 line
# (tools/virtual-uno's virtual-line, 19200 8E1): examples/tcp_gateway.rs on a virtual Uno with
# a virtual W5100 shield (DE on pin 3, the shield's port 502 on 127.0.0.1:$TCP_PORT, 1502),
# the lab's button box (examples/lab_lights.rs, unit 1, DE on pin 10) and light tower (the
# same firmware with pin 12 to GND, unit 2), and pymodbus's serial server as unit 3 on a pty
# (demo/plant_slave.py). A SCADA stand-in, mbpoll -m tcp, talks to all of them through the
# gateway: reads the box's buttons and the tower's lamps, presses START on the box (a pin
# command) and sees it in its reads, writes the tower's coils and sees the lamps change (the
# watched pins), reads and writes unit 3's registers, gets 0B from a unit nobody answers and 0A
# from one the gateway does not route, and reads the gateway's own registers at unit 255.
# Every frame on the line is printed with its sender, every Modbus TCP request and answer with
# its connection, transaction id, unit and function; exits 0 only if every answer was right
# and no frame collided or failed its CRC.
#
# Needs the firmware (make firmware: lab_lights.elf; make tcp-firmware: tcp_gateway.elf), mbpoll
# and Debian's python3-pymodbus 3.0 with python3-serial-asyncio (make setup). Builds
# virtual-line (release) unless $VIRTUAL_LINE names one.
#
#   demo/plant.sh            # the checks, then stop
#   demo/plant.sh --serve    # the checks, then keep the plant running (Ctrl-C stops it):
#                            # QModMaster: Modbus TCP, 127.0.0.1, port 1502, Slave Addr 1, 2, 3, 255
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
target=${CARGO_TARGET_DIR:-$root/target}
port=${TCP_PORT:-1502}
serve=false
[ "${1:-}" = --serve ] && serve=true
lab=$target/avr-atmega328p/release/examples/lab_lights.elf
gateway=$target/chips/atmega328p-tcp-gateway/avr-none/release/examples/tcp_gateway.elf
python=/usr/bin/python3

die() { printf 'demo-plant: %s\n' "$*" >&2; exit 1; }
[ -f "$lab" ] || die "$lab is missing: run make firmware first"
[ -f "$gateway" ] || die "$gateway is missing: run make tcp-firmware first"
command -v mbpoll >/dev/null || die "mbpoll is missing: run make setup"
"$python" -c 'import pymodbus, serial_asyncio' 2>/dev/null || die "python3-pymodbus or python3-serial-asyncio is missing: run make setup"
if [ -z "${VIRTUAL_LINE:-}" ]; then
  "$root/.ci/cargo" build --release --quiet -p virtual-uno --bin virtual-line
  VIRTUAL_LINE=$target/release/virtual-line
fi
[ -x "$VIRTUAL_LINE" ] || die "$VIRTUAL_LINE is missing"

if (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then
  die "127.0.0.1:$port is taken (another virtual board, a test?): TCP_PORT=N for another port"
fi

work=$(mktemp -d)
log=$work/plant.log
control=$work/control
tty=$work/ttyPLANT
: >"$log"
"$VIRTUAL_LINE" --control "$control" --no-stdin \
  --board "gateway=$gateway" de=3 wiznet=w5100 tcp=502:"$port" watch=none \
  --board "box=$lab" de=10 watch=2,3 \
  --board "tower=$lab" de=10 pin12=low watch=4,5,6,7 \
  --pty "pymodbus=$tty" \
  >>"$log" 2>&1 &
line=$!
slave=
tail -n +1 -f "$log" &
tailer=$!
stop_all() {
  if [ -n "$slave" ]; then
    kill -TERM "$slave" 2>/dev/null || true
    wait "$slave" 2>/dev/null || true
    slave=
  fi
  kill -TERM "$line" 2>/dev/null || true
  wait "$line" 2>/dev/null || true
  sleep 0.3
  kill "$tailer" 2>/dev/null || true
  wait "$tailer" 2>/dev/null || true
}
cleanup() {
  local rc=$?
  stop_all
  rm -rf "$work"
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# wait_for PATTERN [SECONDS]: waits for a line of the log matching PATTERN after the last
# line matched before (5 s by default).
mark=1
wait_for() {
  local deadline=$((SECONDS + ${2:-5}))
  while [ "$SECONDS" -le "$deadline" ]; do
    kill -0 "$line" 2>/dev/null || return 1
    local found
    found=$(tail -n +"$mark" "$log" | grep -n -m1 -e "$1" || true)
    if [ -n "$found" ]; then
      mark=$((mark + ${found%%:*}))
      return 0
    fi
    sleep 0.05
  done
  return 1
}

for _ in $(seq 100); do
  [ -e "$tty" ] && break
  sleep 0.05
done
"$python" "$root/demo/plant_slave.py" "$tty" --unit 3 --resync --turnaround-ms 2 >>"$log" 2>&1 &
slave=$!
wait_for "gateway tcp: 127.0.0.1:$port" 10 || die "the gateway never listened on 127.0.0.1:$port"
wait_for "plant_slave: unit 3 on" 10 || die "pymodbus's server did not start"

failed=0
checks=0
# ask DESCRIPTION EXPECTED "OPTIONS" [VALUES...]: one mbpoll, the SCADA's request through the
# gateway (the values after the host: a write); its answer printed and checked for EXPECTED.
ask() {
  local what=$1 expected=$2 options=$3
  shift 3
  local out
  # shellcheck disable=SC2086 # the options are words
  out=$(mbpoll -m tcp -p "$port" -1 -o 2 $options 127.0.0.1 "$@" 2>&1 || true)
  checks=$((checks + 1))
  printf '\n=== SCADA: mbpoll -m tcp -p %s -1 %s 127.0.0.1 %s   # %s\n' "$port" "$options" "$*" "$what"
  grep -e '^\[' -e 'Written' -e 'failed' <<<"$out" | sed 's/^/=== /' || true
  if ! grep -q -- "$expected" <<<"$out"; then
    echo "=== FAILED: expected \"$expected\""
    failed=$((failed + 1))
  fi
}
# pyask DESCRIPTION EXPECTED UNIT: pymodbus's TCP client reads 40001 of UNIT through the
# gateway (mbpoll cannot ask units 248-254: libmodbus's modbus_set_slave refuses them over TCP
# and mbpoll then sends its request to unit 255); prints the answer, checks it for EXPECTED.
pyask() {
  local what=$1 expected=$2 unit=$3 out
  out=$("$python" - "$port" "$unit" 2>&1 <<'PY' || true
import sys
from pymodbus.client import ModbusTcpClient
client = ModbusTcpClient("127.0.0.1", port=int(sys.argv[1]), timeout=2)
client.connect()
reply = client.read_holding_registers(0, 1, slave=int(sys.argv[2]))
code = getattr(reply, "exception_code", None)
print("exception %02X" % code if code is not None else "registers %s" % getattr(reply, "registers", reply))
client.close()
PY
)
  checks=$((checks + 1))
  printf '\n=== SCADA: pymodbus ModbusTcpClient read_holding_registers(0, 1, slave=%s)   # %s\n' "$unit" "$what"
  echo "=== $out"
  if ! grep -q -- "$expected" <<<"$out"; then
    echo "=== FAILED: expected \"$expected\""
    failed=$((failed + 1))
  fi
}
# lamps STATE: waits for the tower's watched pins to show STATE (`4=on 5=off 6=on 7=off`).
lamps() {
  checks=$((checks + 1))
  if wait_for "tower pins: $1"; then
    echo "=== the tower's lamps: $1"
  else
    echo "=== FAILED: the tower's lamps never showed $1"
    failed=$((failed + 1))
  fi
}

echo "=== demo-plant: SCADA -> Modbus TCP 127.0.0.1:$port -> gateway (unit 255) -> RS-485 19200 8E1 -> box (1), tower (2), pymodbus (3)"
ask "the box's buttons, 10001-10002: none pressed" "\[1\]: 	0" "-a 1 -t 1 -r 1 -c 2"
ask "the tower's lamps, 00001-00004: all off" "\[4\]: 	0" "-a 2 -t 0 -r 1 -c 4"
echo "set box pin2 low" >"$control"
wait_for "set: set box pin2 low" || true
ask "START held down (box pin 2 to GND): 10001 reads 1" "\[1\]: 	1" "-a 1 -t 1 -r 1 -c 2"
echo "set box pin2 z" >"$control"
wait_for "set: set box pin2 z" || true
ask "START released: 10001 reads 0 again" "\[1\]: 	0" "-a 1 -t 1 -r 1 -c 2"
ask "RED and YELLOW on: coils 00001-00004 = 1 0 1 0 (FC 15)" "Written 4 references" "-a 2 -t 0 -r 1" 1 0 1 0
lamps "4=on 5=off 6=on 7=off"
ask "GREEN on too: coil 00002 = 1 (FC 5)" "Written 1 references" "-a 2 -t 0 -r 2" 1
lamps "4=on 5=on 6=on 7=off"
ask "the lamps read back" "\[2\]: 	1" "-a 2 -t 0 -r 1 -c 4"
ask "pymodbus's unit 3, holding registers 40001-40004" "\[4\]: 	771" "-a 3 -t 4 -r 1 -c 4"
ask "unit 3: 40001-40002 = 7 8 (FC 16)" "Written 2 references" "-a 3 -t 4 -r 1" 7 8
checks=$((checks + 1))
if wait_for "plant_slave: unit 3 holding 0-1 <- \[7, 8\]"; then
  echo "=== pymodbus executed the write"
else
  echo "=== FAILED: pymodbus never reported the write"
  failed=$((failed + 1))
fi
ask "unit 3: read back" "\[2\]: 	8" "-a 3 -t 4 -r 1 -c 2"
ask "unit 3: input registers 30001-30002" "\[2\]: 	12289" "-a 3 -t 3 -r 1 -c 2"
ask "unit 7: nobody answers on the line: exception 0B" "Target device failed to respond" "-a 7 -t 4 -r 1"
pyask "unit 250: not routed: exception 0A" "exception 0A" 250
ask "the gateway itself, unit 255: 40001-40009 (requests sent, answers, exceptions, 0A sent, 0B sent, ...)" "\[4\]: 	1$" "-a 255 -t 4 -r 1 -c 9"

if $serve && [ "$failed" -eq 0 ]; then
  echo "=== the plant keeps running: Modbus TCP on 127.0.0.1:$port (units 1, 2, 3 and 255); Ctrl-C stops it"
  echo "=== buttons: echo 'set box pin2 low' > $control (pin3: STOP; z releases)"
  wait "$line" || true
fi
stop_all

frames=$(grep -c 'frame from' "$log" || true)
bad=$(grep 'frame from' "$log" | grep -c -e 'COLLISION' -e 'bad CRC' -e 'too short' -e 'cut' || true)
requests=$(grep -c 'gateway conn .* request tid' "$log" || true)
answers=$(grep -c 'gateway conn .* answer tid' "$log" || true)
echo
echo "=== demo-plant: $checks checks, $((checks - failed)) passed; $requests TCP requests, $answers answers; $frames frames on the line"
grep -o 'frames: [^;]*' "$log" | tail -n 1 | sed 's/^/=== /' || true
[ "$bad" -eq 0 ] || { echo "=== $bad frames collided, were cut or failed their CRC"; failed=$((failed + 1)); }
short=$(grep 'frame from' "$log" | grep -c 'character times after the previous frame' || true)
[ "$short" -eq 0 ] || echo "=== $short frames came after less than 3.5 character times of silence"
if [ "$failed" -ne 0 ]; then
  echo "=== FAILED"
  exit 1
fi
echo "=== the SCADA saw the buttons, lit the lamps and reached pymodbus, all through the gateway"
