#!/usr/bin/env python3
"""pymodbus's payload decoder and builder (BinaryPayloadDecoder, BinaryPayloadBuilder) against
examples/meter.rs: floats and 32-bit counters in both word orders, and a counter read many
times, never torn.

Usage: pymodbus_wide.py PORT [--reads N]   (19200, slave 1; parity N on the virtual board's pty, which
carries no parity bit, while the firmware runs 8E1)
"""
import argparse
import sys

from pymodbus.client import ModbusSerialClient
from pymodbus.constants import Endian
from pymodbus.payload import BinaryPayloadBuilder, BinaryPayloadDecoder

FAILED = []


def step(name, got, want):
    ok = got == want
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {got!r}{'' if ok else f' (expected {want!r})'}", flush=True)
    if not ok:
        FAILED.append(name)


def registers(response, count):
    if response.isError() or len(response.registers) != count:
        return None
    return response.registers


def decoder(regs, wordorder):
    return BinaryPayloadDecoder.fromRegisters(regs, byteorder=Endian.Big, wordorder=wordorder)


def builder(wordorder):
    return BinaryPayloadBuilder(byteorder=Endian.Big, wordorder=wordorder)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("port")
    parser.add_argument("--reads", type=int, default=500)
    parser.add_argument("--control", help="the virtual board's control file (unused)")
    args = parser.parse_args()
    client = ModbusSerialClient(args.port, baudrate=19200, parity="N", stopbits=1, bytesize=8, timeout=1, retries=0)
    if not client.connect():
        print(f"FAIL cannot open {args.port}")
        return 1
    try:
        regs = registers(client.read_holding_registers(0, 2, slave=1), 2)
        step("40001-40002 as f32, high word first", decoder(regs, Endian.Big).decode_32bit_float(), 1.5)
        step("the same registers decoded low word first are not 1.5",
             decoder(regs, Endian.Little).decode_32bit_float() != 1.5, True)

        payload = builder(Endian.Big)
        payload.add_32bit_float(-2.25)
        client.write_registers(0, payload.to_registers(), slave=1)
        regs = registers(client.read_input_registers(2, 2, slave=1), 2)
        step("30003-30004 = 40001-40002 x 2, f32 high word first", decoder(regs, Endian.Big).decode_32bit_float(), -4.5)

        payload = builder(Endian.Little)
        payload.add_32bit_uint(0x0001FFFF)
        written = payload.to_registers()
        step("0x0001FFFF built low word first", written, [0xFFFF, 0x0001])
        client.write_registers(2, written, slave=1)
        regs = registers(client.read_input_registers(4, 2, slave=1), 2)
        step("30005-30006 = 40003-40004 + 1, u32 low word first",
             decoder(regs, Endian.Little).decode_32bit_uint(), 0x00020000)

        torn = 0
        answered = 0
        for _ in range(args.reads):
            regs = registers(client.read_input_registers(0, 2, slave=1), 2)
            if regs is None:
                continue
            answered += 1
            value = decoder(regs, Endian.Big).decode_32bit_uint()
            if value >> 16 != value & 0xFFFF:
                torn += 1
        step(f"30001-30002 u32 read {args.reads} times: answered", answered, args.reads)
        step("torn reads (words differ)", torn, 0)
    finally:
        client.close()
    if FAILED:
        print(f"{len(FAILED)} step(s) failed: {', '.join(FAILED)}")
        return 1
    print("all steps passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
