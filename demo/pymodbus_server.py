#!/usr/bin/env python3
"""A pymodbus serial RTU server with two slaves, for a Modbus *master* to poll.

    python3 demo/pymodbus_server.py PORT [--seconds 8] [--baud 19200] [--parity N]
                                         [--no-broadcast] [--debug]

Unit 1, the slave polled (protocol addresses, i.e. address 0 is register 0):
    holding registers 0-15   0x1000 + i
    holding registers 16-19  1.5 as f32 high word first (3FC0 0000), then low word first (0000 3FC0)
    input registers 0-2      0x2000 + i
    coils 0-15               on at even addresses (0, 2, 4, ...)
    discrete inputs 0-7      on at addresses 0, 1, 4, 5 (0b0011_0011)
Unit 2, the slave told: 256 holding registers of zeros.

It serves PORT for --seconds, then prints one JSON line on stdout and exits 0:
    {"unit1_holding": [0..255], "unit2_holding": [0..255], "unit1_coils": [0..15],
     "unit1_inputs": [...], "unit1_input_registers": [...], "counter_log": [[...], ...],
     "broadcast": true}
Addresses past a block read as null. `counter_log` lists every write that covered unit 2's
registers 240-250 (examples/master_mirror.rs's counters and pass count), oldest first.

Unit-0 broadcasts: pymodbus 3.0's server drops them unless `broadcast_enable=True` (then it
executes them on every unit and sends no reply); this script enables it unless
--no-broadcast. With a pty, use parity N: a pty carries no parity bit.

Debian: apt-get install python3-pymodbus python3-serial-asyncio (pymodbus 3.0).
"""

import argparse
import asyncio
import json
import logging
import sys

from pymodbus.datastore import (
    ModbusSequentialDataBlock,
    ModbusServerContext,
    ModbusSlaveContext,
)
from pymodbus.server import StartAsyncSerialServer
from pymodbus.transaction import ModbusRtuFramer

HOLDING = [0x1000 + i for i in range(16)] + [0x3FC0, 0x0000, 0x0000, 0x3FC0]
INPUT_REGISTERS = [0x2000 + i for i in range(3)]
COILS = [i % 2 == 0 for i in range(16)]
DISCRETE = [bool(0b0011_0011 >> i & 1) for i in range(8)]

COUNTERS = 240  # unit 2: the master's counters at 240-249, its pass count at 250
COUNTER_COUNT = 11


class LoggedBlock(ModbusSequentialDataBlock):
    """Unit 2's holding registers: remembers each write of the counters block."""

    def __init__(self, address, values):
        super().__init__(address, values)
        self.counter_log = []

    def setValues(self, address, values):  # pylint: disable=invalid-name
        super().setValues(address, values)
        if not isinstance(values, list):
            values = [values]
        if address <= COUNTERS and address + len(values) >= COUNTERS + COUNTER_COUNT:
            self.counter_log.append(self.getValues(COUNTERS, COUNTER_COUNT))


def read(block, count):
    """Values 0..count-1 of a data block, None where the block has none."""
    return [block.getValues(a, 1)[0] if block.validate(a, 1) else None for a in range(count)]


async def serve(args):
    unit1 = ModbusSlaveContext(
        di=ModbusSequentialDataBlock(0, list(DISCRETE)),
        co=ModbusSequentialDataBlock(0, list(COILS)),
        hr=ModbusSequentialDataBlock(0, list(HOLDING)),
        ir=ModbusSequentialDataBlock(0, list(INPUT_REGISTERS)),
        zero_mode=True,  # pymodbus 3.0 otherwise adds 1 to every protocol address
    )
    told = LoggedBlock(0, [0] * 256)
    unit2 = ModbusSlaveContext(
        di=ModbusSequentialDataBlock(0, [False]),
        co=ModbusSequentialDataBlock(0, [False]),
        hr=told,
        ir=ModbusSequentialDataBlock(0, [0]),
        zero_mode=True,
    )
    context = ModbusServerContext(slaves={1: unit1, 2: unit2}, single=False)
    server = await StartAsyncSerialServer(
        context=context,
        framer=ModbusRtuFramer,
        port=args.port,
        baudrate=args.baud,
        parity=args.parity,
        bytesize=8,
        stopbits=1,
        timeout=0.005,
        broadcast_enable=not args.no_broadcast,
        defer_start=True,
    )
    await server.start()
    if server.transport is None:
        print(f"pymodbus_server: cannot open {args.port}", file=sys.stderr)
        return 1
    print(f"pymodbus_server: serving units 1 and 2 on {args.port} for {args.seconds} s", file=sys.stderr)
    await asyncio.sleep(args.seconds)
    if not args.debug:  # stopping cancels the port's handler, which pymodbus logs as an error
        logging.getLogger("pymodbus.server.async_io").setLevel(logging.CRITICAL)
    await server.shutdown()

    result = {
        "unit1_holding": read(unit1.store["h"], 256),
        "unit2_holding": read(told, 256),
        "unit1_coils": [int(bit) for bit in read(unit1.store["c"], 16)],
        "unit1_inputs": [int(bit) for bit in read(unit1.store["d"], 8)],
        "unit1_input_registers": read(unit1.store["i"], 3),
        "counter_log": told.counter_log,
        "broadcast": not args.no_broadcast,
    }
    print(json.dumps(result, separators=(",", ":")), flush=True)
    return 0


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("port")
    parser.add_argument("--seconds", type=float, default=8.0)
    parser.add_argument("--baud", type=int, default=19200)
    parser.add_argument("--parity", default="N", choices="NEO")
    parser.add_argument("--no-broadcast", action="store_true", help="leave pymodbus's default: ignore unit 0")
    parser.add_argument("--debug", action="store_true", help="pymodbus's debug log on stderr")
    args = parser.parse_args()
    logging.basicConfig(stream=sys.stderr, level=logging.DEBUG if args.debug else logging.WARNING)
    if not args.debug:  # pymodbus logs each exception reply it sends (here 02, once a pass) as an error
        logging.getLogger("pymodbus.pdu").setLevel(logging.CRITICAL)
    return asyncio.run(serve(args))


if __name__ == "__main__":
    sys.exit(main())
