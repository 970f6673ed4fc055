#!/usr/bin/env bash
# `make serve EXAMPLE=uno_slave`: keeps an example running on the virtual Uno for QModMaster or
# any other Modbus RTU (or, for a 7-bit firmware such as `ascii`, ASCII) master, and says which
# settings to enter. Type commands to change the
# inputs (`pin 6 0`, `adc A0 2500`, `pins`); Ctrl-C stops.
#
#   demo/serve.sh [EXAMPLE] [virtual-uno options, e.g. --pin 10=0 for dip_switch]
#   SERVE_PORT=/tmp/ttyUNO (default) names the symlink to the pty.
#   SERVE_SHIELD=w5100|w5500 puts an Ethernet shield on the SPI port, SERVE_TCP=502:1502 bridges the
#   chip's port 502 to 127.0.0.1:1502 (make serve SHIELD=w5100 TCP_PORT=1502 sets these).
#
# Another board (make serve BOARD=mega2560 USART=1 sets these): SERVE_BOARD (uno), SERVE_CHIP
# (atmega328p), SERVE_USART (0), SERVE_ELF (the firmware built for that chip and USART). The
# pin commands and --pin/--watch take the Uno's pin numbers: they work on the Uno's chips
# (ATmega328P, ATmega168) only.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
target=${CARGO_TARGET_DIR:-$root/target}
example=${1:-uno_slave}
[ $# -gt 0 ] && shift
board=${SERVE_BOARD:-uno}
chip=${SERVE_CHIP:-atmega328p}
usart=${SERVE_USART:-0}
elf=${SERVE_ELF:-$target/avr-atmega328p/release/examples/$example.elf}
port=${SERVE_PORT:-/tmp/ttyUNO}
shield=${SERVE_SHIELD:-}
tcp=${SERVE_TCP:-502:1502}
shield_args=()
[ -n "$shield" ] && shield_args=(--wiznet "$shield" --tcp "$tcp")

if [ ! -f "$elf" ]; then
  case $chip in
    atmega328p) echo "serve: $elf is missing: run make firmware first" >&2 ;;
    *) echo "serve: $elf is missing: build $example for the $chip (USART$usart) first" >&2 ;;
  esac
  exit 1
fi
"$root/.ci/cargo" build --release --quiet -p virtual-uno

# The board's Arduino pins for its USART: RX, then TX.
case $board:$usart in
  uno:0 | nano:0 | promini:0 | nano168:0) pins="pins 0 (RX) and 1 (TX), shared with the USB serial port" ;;
  mega2560:0 | mega1280:0) pins="pins 0 (RX) and 1 (TX), shared with the USB serial port" ;;
  mega2560:1 | mega1280:1) pins="pins 19 (RX1) and 18 (TX1)" ;;
  mega2560:2 | mega1280:2) pins="pins 17 (RX2) and 16 (TX2)" ;;
  mega2560:3 | mega1280:3) pins="pins 15 (RX3) and 14 (TX3)" ;;
  leonardo:1 | promicro:1 | micro:1) pins="pins 0 (RX) and 1 (TX); USB is the chip's own" ;;
  *) pins="the $board has no USART$usart" ;;
esac
# What can be typed while it runs: pin numbers are the Uno's.
case $chip in
  atmega328p | atmega168) commands="pin 6 0 | pin 6 z | adc A0 2500 | pins" ;;
  *) commands="adc A0 2500 (pin numbers are the Uno's: no pin commands on the $chip)" ;;
esac

# How to reach the slave, once the firmware has set up its USART ("serial: 19200 8E1 ...").
settings() {
  local baud=${1%% *} format=${1#* }
  local parity python_parity python_note strict=""
  case ${format:1:1} in N) parity=None ;; E) parity=Even ;; O) parity=Odd ;; *) parity=${format:1:1} ;; esac
  # pyserial and a pty's missing parity bit: docs/masters.md, "Python masters".
  case ${format:1:1} in
    N) python_parity=N python_note="as the slave" ;;
    E) python_parity=N python_note="not E: pyserial gets EINVAL setting even parity on a pty; none is served like even" ;;
    *) python_parity=${format:1:1} python_note="pymodbus: with strict=False, once per virtual Uno; minimalmodbus: always"
       strict=", strict=False" ;;
  esac
  # 7 data bits: Modbus ASCII (Modbus RTU needs 8).
  if [ "${format:0:1}" = 7 ]; then
    cat <<TEXT

  Connect a Modbus ASCII master to $port (the pty printed above), slave id 1, $baud $format:
    pymodbus:   from pymodbus.framer.ascii_framer import ModbusAsciiFramer  (pymodbus 3.0)
                ModbusSerialClient("$port", framer=ModbusAsciiFramer, baudrate=$baud, bytesize=7,
                                   parity="${format:1:1}", stopbits=${format:2:1}, timeout=1, strict=False), then slave=1 on each call
    QModMaster and mbpoll speak RTU and TCP only (libmodbus has no ASCII): they can't reach it.
  A pty passes on the characters and the baud rate, not the data bits or parity.
  Type here: $commands    Ctrl-C stops.

TEXT
    return
  fi
  cat <<TEXT

  Connect a Modbus RTU master to $port (the pty printed above), slave id 1:
    QModMaster: Options > Modbus RTU: type $port as Serial port ("Add Port" is no dialog),
                Baud $baud, Data Bits ${format:0:1}, Stop Bits ${format:2:1}, Parity $parity, RTS None; OK;
                then Modbus Mode RTU, Slave Addr 1, Connect. Start Address counts from 0:
                40001 is Read Holding Registers at 0, 00002 Read Coils at 1 (leave
                Options > Settings > Base Addr at 0); function, address and count of each
                table: the header of examples/$example.rs.
    mbpoll:     mbpoll -m rtu -b $baud -P ${parity,,} -s ${format:2:1} -a 1 -t 3 -c 5 $port
    Python:     parity "$python_parity" ($python_note)
      pymodbus:      ModbusSerialClient("$port", baudrate=$baud, parity="$python_parity",
                                        stopbits=${format:2:1}, bytesize=8, timeout=1$strict), then slave=1 on each call
      minimalmodbus: uno = minimalmodbus.Instrument("$port", 1)
                     uno.serial.baudrate = $baud; uno.serial.parity = "$python_parity"; uno.serial.stopbits = ${format:2:1}
  A master at another baud rate, stop bits or odd parity gets no answer, and the virtual board
  says why (a pty does not pass on whether parity is none or even: both are served).
  Type here: $commands    Ctrl-C stops.

TEXT
}

echo "serve: $example on a virtual $board: $chip, USART$usart ($pins)"
tcp_settings() {
  local host=${1%:*} tcp_port=${1##*:}
  cat <<TEXT

  Connect a Modbus TCP master to $host port $tcp_port (the $shield's port ${tcp%%:*}), unit id 1:
    mbpoll:     mbpoll -m tcp -p $tcp_port -a 1 -t 3 -c 5 $host
    QModMaster: Modbus Mode TCP, Slave IP $host, TCP Port $tcp_port, Slave Addr 1, Connect.
    pymodbus:   ModbusTcpClient("$host", port=$tcp_port), then slave=1 on each call

TEXT
}

[ -n "$shield" ] && echo "serve: an Ethernet shield with a $shield, its port ${tcp%%:*} on 127.0.0.1:${tcp##*:}"
"$target/release/virtual-uno" --link "$port" --usart "$usart" "${shield_args[@]}" "$@" "$elf" | while IFS= read -r line; do
  printf '%s\n' "$line"
  case $line in
    "chip: $chip,"*) ;;
    "chip: "*) built=${line#chip: } && echo "serve: warning: $elf is built for ${built%%,*}, not the $board's $chip" >&2 ;;
    "serial: off"*) ;;
    "tcp: 127.0.0.1:"*" (the chip's port "*) addr=${line#tcp: } && tcp_settings "${addr%% *}" ;;
    "serial: "*) settings "$(sed 's/^serial: \([0-9]* [5-9][NEO][12]\).*/\1/' <<<"$line")" ;;
  esac
done
