#!/usr/bin/env python3
"""Polls the firmware on a (virtual) Uno with pymodbus and checks every answer.

Every function code the slave supports (01 02 03 04 05 06 15 16), exceptions 01, 02 and 03,
a broadcast write read back afterwards, then N back-to-back reads with the answer rate.

    pymodbus_check.py PORT [--board uno_slave|dip_switch|ascii|configurable|units|boards] [--baud 19200]
                      [--parity E] [--stop 1] [--control FIFO] [--preset N] [--reads 1000]
                      [--rounds 40]

--board ascii talks Modbus ASCII (pymodbus's ASCII framer, 7 data bits) to examples/ascii.rs.
--board configurable reads examples/configurable.rs's settings block and its device
identification (FC 43 / MEI 14, every read device id code, exceptions 02 and 03).
--board units polls examples/units.rs's four slave ids (1-4) one after the other, writes each
and all of them at once (a broadcast), and checks that id 5 does not answer.
--board boards polls the peers' contract map of examples/boards.rs (on the virtual Uno's pins
8/9 with `--pins 8,9`: its capture-line build); --rounds N then writes and reads back N times
(FC 16, 03, 06, 03, 05, 15, 01, 04: eight requests a round) and prints the requests and errors.

--control is the virtual Uno's command FIFO: the uno_slave checks close a switch and turn a
potentiometer through it. Prints one line per step; exits 1 if any step went wrong.
Written for pymodbus 3.0 (Debian 12's python3-pymodbus); `slave=` is passed everywhere.
`strict=False`: with it pyserial sets the line twice, and on a Linux pty (which drops PARENB)
the second tcsetattr with parity fails with EINVAL. Even then, parity E or O works only for
the first pyserial connection to a pty: pyserial leaves the pty at the new speed, and the
next connection's tcsetattr, whose only change is PARENB, fails the same way. Users of the
virtual Uno set parity N instead (docs/masters.md, "Python masters").
"""

import argparse
import os
import sys
import time

from pymodbus.client import ModbusSerialClient
from pymodbus.pdu import ExceptionResponse

try:
    from pymodbus.framer.ascii_framer import ModbusAsciiFramer
except ImportError:  # pymodbus >= 3.7
    from pymodbus.framer import FramerAscii as ModbusAsciiFramer

try:
    from pymodbus.mei_message import ReadDeviceInformationRequest
except ImportError:  # pymodbus >= 3.7
    from pymodbus.pdu.mei_message import ReadDeviceInformationRequest

FAILED = []


def step(name, got, want):
    """Prints one step of the transcript and remembers a mismatch."""
    ok = got == want
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {got}" + ("" if ok else f" (expected {want})"), flush=True)
    if not ok:
        FAILED.append(name)


def values(response, field, count):
    """The bits or registers of a response, or a short description of what came instead."""
    if response is None or isinstance(response, Exception):
        return f"no answer ({response})"
    if response.isError():
        code = getattr(response, "exception_code", None)
        return f"exception {code:02d}" if code is not None else f"error {response}"
    data = getattr(response, field)
    return [int(v) for v in data[:count]]


def exception(response):
    """`exception NN` for an exception response, else a description."""
    if isinstance(response, ExceptionResponse):
        return f"exception {response.exception_code:02d}"
    return f"no exception ({response})"


def control(path, command):
    """Sends a command to the virtual Uno and gives the firmware's loop time to see it."""
    with open(path, "w", encoding="ascii") as fifo:
        fifo.write(command + "\n")
    time.sleep(0.1)


def uno_slave(client, args):
    """The classic demo's register map (examples/uno_slave.rs)."""
    step("FC01 read coils 00001-00005", values(client.read_coils(0, 5, slave=1), "bits", 5), [0] * 5)
    if args.control:
        control(args.control, "pin 6 0")
    step("FC02 read discrete inputs 10001-10004 (switch on pin 6 closed)",
         values(client.read_discrete_inputs(0, 4, slave=1), "bits", 4), [1, 0, 0, 0])
    if args.control:
        control(args.control, "adc A0 2500")
    regs = values(client.read_input_registers(0, 3, slave=1), "registers", 3)
    step("FC04 read input registers 30001-30003 (A0 at 2.5 V)", regs[:1] if isinstance(regs, list) else regs, [511])
    step("FC03 read holding registers 40001-40002 (defaults)",
         values(client.read_holding_registers(0, 2, slave=1), "registers", 2), [500, 512])
    step("FC05 write coil 00002 on", exception_or_ok(client.write_coil(1, True, slave=1)), "ok")
    step("FC15 write coils 00003-00005 = 1 0 1", exception_or_ok(client.write_coils(2, [True, False, True], slave=1)),
         "ok")
    step("FC01 read back coils 00001-00005", values(client.read_coils(0, 5, slave=1), "bits", 5), [0, 1, 1, 0, 1])
    step("FC06 write register 40003 = 1234", exception_or_ok(client.write_register(2, 1234, slave=1)), "ok")
    step("FC16 write registers 40004-40006 = 11 22 33",
         exception_or_ok(client.write_registers(3, [11, 22, 33], slave=1)), "ok")
    step("FC03 read back 40003-40006", values(client.read_holding_registers(2, 4, slave=1), "registers", 4),
         [1234, 11, 22, 33])
    common_exceptions_and_broadcast(client, holding=10)


def units(client, args):
    """Four sensors at slave ids 1-4 (examples/units.rs), each its own register map."""
    for unit in range(1, 5):
        step(f"slave {unit}: FC04 read 30001 (its reading)",
             values(client.read_input_registers(0, 1, slave=unit), "registers", 1), [100 * unit])
    for unit in range(1, 5):
        step(f"slave {unit}: FC06 write 40001 = {10 + unit}",
             exception_or_ok(client.write_register(0, 10 + unit, slave=unit)), "ok")
    for unit in range(1, 5):
        step(f"slave {unit}: FC03 read 40001-40002",
             values(client.read_holding_registers(0, 2, slave=unit), "registers", 2), [10 + unit, 0])
    client.write_register(1, 55, slave=0)
    time.sleep(0.05)
    for unit in range(1, 5):
        step(f"slave {unit}: FC03 read 40001-40002 after broadcast FC06 40002 = 55",
             values(client.read_holding_registers(0, 2, slave=unit), "registers", 2), [10 + unit, 55])
        step(f"slave {unit}: FC04 read 30002 (the firmware's copy of 40001)",
             values(client.read_input_registers(1, 1, slave=unit), "registers", 1), [10 + unit])
    step("slave 2: FC03 read 40003 (missing)", exception(client.read_holding_registers(2, 1, slave=2)), "exception 02")
    if args.reads:
        answered = sum(values(client.read_input_registers(0, 1, slave=1 + i % 4), "registers", 1) == [100 * (1 + i % 4)]
                       for i in range(args.reads))
        step(f"{args.reads} reads, slaves 1-4 in turn: answered right", answered, args.reads)
        args.reads = 0
    # Last: pymodbus 3.0 reopens the port after a timeout, which a pty refuses at parity E.
    step("slave 5: FC04 read 30001 (no such slave)", exception_or_silence(client.read_input_registers(0, 1, slave=5)),
         "no answer")


def contract_boards(client, args):
    """The peers' contract map (examples/boards.rs): 16 coils, 16 inputs, 8 input and 16 holding
    registers, 30001 counting seconds; then --rounds rounds of writes, each read back."""
    step("FC01 read coils 00001-00016", values(client.read_coils(0, 16, slave=1), "bits", 16), [0] * 16)
    step("FC02 read discrete inputs 10001-10016", values(client.read_discrete_inputs(0, 16, slave=1), "bits", 16),
         [0] * 16)
    regs = values(client.read_input_registers(0, 8, slave=1), "registers", 8)
    step("FC04 read 30002-30008 (30001 counts seconds)", regs[1:] if isinstance(regs, list) else regs, [0] * 7)
    step("FC03 read 40001-40016", values(client.read_holding_registers(0, 16, slave=1), "registers", 16), [0] * 16)
    common_exceptions_and_broadcast(client, holding=16)
    requests = errors = 0
    seconds = 0
    start = time.monotonic()
    for r in range(args.rounds):
        block = [(r * 16 + i) * 257 & 0xFFFF for i in range(16)]
        one, coil = r % 16, r % 2 == 0
        pattern = [bool(r >> i & 1) for i in range(16)]
        checks = [
            ("FC16 40001-40016", lambda: exception_or_ok(client.write_registers(0, block, slave=1)), "ok"),
            ("FC03 40001-40016", lambda: values(client.read_holding_registers(0, 16, slave=1), "registers", 16),
             block),
            (f"FC06 {40001 + one}", lambda: exception_or_ok(client.write_register(one, 50000 + r, slave=1)), "ok"),
            (f"FC03 {40001 + one}", lambda: values(client.read_holding_registers(one, 1, slave=1), "registers", 1),
             [50000 + r]),
            ("FC15 00001-00016", lambda: exception_or_ok(client.write_coils(0, pattern, slave=1)), "ok"),
            (f"FC05 {1 + one:05d}", lambda: exception_or_ok(client.write_coil(one, coil, slave=1)), "ok"),
            ("FC01 00001-00016", lambda: values(client.read_coils(0, 16, slave=1), "bits", 16),
             [int(coil) if i == one else int(b) for i, b in enumerate(pattern)]),
        ]
        for name, ask, want in checks:
            requests += 1
            got = ask()
            if got != want:
                errors += 1
                print(f"FAIL round {r}: {name}: {got} (expected {want})", flush=True)
        requests += 1
        now = values(client.read_input_registers(0, 1, slave=1), "registers", 1)
        if not isinstance(now, list) or now[0] < seconds:
            errors += 1
            print(f"FAIL round {r}: FC04 30001: {now} (seconds were {seconds})", flush=True)
        else:
            seconds = now[0]
    took = time.monotonic() - start
    if args.rounds:
        print(f"{'ok  ' if errors == 0 else 'FAIL'} {args.rounds} rounds: {requests} requests, {errors} errors "
              f"in {took:.1f} s ({1000.0 * took / requests:.1f} ms each); 30001 at {seconds} s", flush=True)
    if errors:
        FAILED.append("rounds")


def exception_or_silence(response):
    """`no answer` when nothing came back, else what did."""
    if response is None or isinstance(response, Exception):
        return "no answer"
    if response.isError() and not isinstance(response, ExceptionResponse):
        return "no answer"
    return f"an answer ({response})"


def dip_switch(client, args):
    """The DIP-switch example (examples/dip_switch.rs): checks the preset it reports."""
    step("FC04 read input register 30001 (preset)",
         values(client.read_input_registers(0, 1, slave=1), "registers", 1), [args.preset])
    bits = [(args.preset >> i) & 1 for i in range(3)]
    step("FC02 read discrete inputs 10001-10003 (DIP switch)",
         values(client.read_discrete_inputs(0, 3, slave=1), "bits", 3), bits)
    step("FC05 write coil 00001 on", exception_or_ok(client.write_coil(0, True, slave=1)), "ok")
    step("FC15 write coils 00010-00012 = 1 1 0", exception_or_ok(client.write_coils(9, [True, True, False], slave=1)),
         "ok")
    step("FC01 read back coils 00009-00012", values(client.read_coils(8, 4, slave=1), "bits", 4), [0, 1, 1, 0])
    step("FC06 write register 40001 = 4660", exception_or_ok(client.write_register(0, 4660, slave=1)), "ok")
    step("FC16 write registers 40002-40003 = 7 8", exception_or_ok(client.write_registers(1, [7, 8], slave=1)), "ok")
    step("FC03 read back 40001-40003", values(client.read_holding_registers(0, 3, slave=1), "registers", 3),
         [4660, 7, 8])
    common_exceptions_and_broadcast(client, holding=10)


def ascii_board(client, args):
    """The ASCII example (examples/ascii.rs), 9600 7E1: every function code, as RTU."""
    if args.control:
        control(args.control, "pin 6 0")
        control(args.control, "adc A0 2500")
    step("FC01 read coils 00001-00004", values(client.read_coils(0, 4, slave=1), "bits", 4), [0] * 4)
    step("FC02 read discrete inputs 10001-10004 (switch on pin 6 closed)",
         values(client.read_discrete_inputs(0, 4, slave=1), "bits", 4), [1, 0, 0, 0])
    regs = values(client.read_input_registers(0, 2, slave=1), "registers", 2)
    step("FC04 read input register 30001 (A0 at 2.5 V)", regs[:1] if isinstance(regs, list) else regs, [511])
    step("FC05 write coil 00002 on", exception_or_ok(client.write_coil(1, True, slave=1)), "ok")
    step("FC15 write coils 00003-00004 = 1 0", exception_or_ok(client.write_coils(2, [True, False], slave=1)), "ok")
    step("FC01 read back coils 00001-00004", values(client.read_coils(0, 4, slave=1), "bits", 4), [0, 1, 1, 0])
    step("FC06 write register 40001 = 1234", exception_or_ok(client.write_register(0, 1234, slave=1)), "ok")
    step("FC16 write registers 40002-40004 = 11 22 33",
         exception_or_ok(client.write_registers(1, [11, 22, 33], slave=1)), "ok")
    step("FC03 read back 40001-40004", values(client.read_holding_registers(0, 4, slave=1), "registers", 4),
         [1234, 11, 22, 33])
    common_exceptions_and_broadcast(client, holding=8)


# What examples/configurable.rs identifies itself as (its header's table); 0x02 is the crate's
# version, read from Cargo.toml.
CONFIGURABLE_OBJECTS = {
    0x00: b"avr-modbus",
    0x01: b"configurable",
    0x04: b"Uno Modbus slave with stored settings",
    0x05: b"Arduino Uno (ATmega328P)",
}


def crate_version():
    """The package version in Cargo.toml beside this script's folder."""
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "Cargo.toml")
    with open(path, encoding="utf-8") as cargo:
        for line in cargo:
            if line.startswith("version"):
                return line.split('"')[1].encode()
    raise SystemExit("no version in Cargo.toml")


def read_device_id(client, code, object_id=0x00):
    """FC 43 / MEI 14 with read device id `code` from `object_id`: pymodbus's response."""
    request = ReadDeviceInformationRequest(read_code=code, object_id=object_id)
    request.unit_id = request.slave_id = 1  # the name changed after pymodbus 3.0
    return client.execute(request)


def identification(response):
    """Conformity level, more follows and the objects of a device identification response."""
    if response is None or isinstance(response, Exception):
        return f"no answer ({response})"
    if response.isError():
        return exception(response)
    return {"conformity": response.conformity, "more follows": response.more_follows,
            "objects": dict(response.information)}


def configurable(client, args):
    """examples/configurable.rs at its default (19200 8E1, slave 1): the settings block and
    Read Device Identification, every code."""
    step("FC03 read 40101-40105 (slave id, baud/100, parity, stop bits, mode)",
         values(client.read_holding_registers(100, 5, slave=1), "registers", 5), [1, 192, 2, 1, 0])
    objects = dict(sorted({**CONFIGURABLE_OBJECTS, 0x02: crate_version()}.items()))
    basic = {k: v for k, v in objects.items() if k <= 0x02}
    step("FC43/14 code 01: basic stream", identification(read_device_id(client, 0x01)),
         {"conformity": 0x82, "more follows": 0, "objects": basic})
    step("FC43/14 code 02: regular stream", identification(read_device_id(client, 0x02)),
         {"conformity": 0x82, "more follows": 0, "objects": objects})
    step("FC43/14 code 03: extended stream, answered at the regular level",
         identification(read_device_id(client, 0x03)),
         {"conformity": 0x82, "more follows": 0, "objects": objects})
    for object_id, value in objects.items():
        step(f"FC43/14 code 04: object {object_id:02X}", identification(read_device_id(client, 0x04, object_id)),
             {"conformity": 0x82, "more follows": 0, "objects": {object_id: value}})
    step("FC43/14 code 04: object 03 (VendorUrl, not given)", identification(read_device_id(client, 0x04, 0x03)),
         "exception 02")
    step("FC43/14 code 05 (no such code)", identification(read_device_id(client, 0x05)), "exception 03")


def exception_or_ok(response):
    """`ok` for a normal answer to a write, else what came instead."""
    if response is None or isinstance(response, Exception):
        return f"no answer ({response})"
    if response.isError():
        return exception(response)
    return "ok"


def common_exceptions_and_broadcast(client, holding):
    """Exceptions 01, 02, 03 and a broadcast write to holding register 40001+holding-1."""
    identification = ReadDeviceInformationRequest()
    identification.unit_id = identification.slave_id = 1  # the name changed after pymodbus 3.0
    step("FC43 read device identification (not supported)", exception(client.execute(identification)),
         "exception 01")
    step(f"FC03 read {40001 + holding}, past the last register",
         exception(client.read_holding_registers(holding, 1, slave=1)), "exception 02")
    step("FC03 read 126 registers (over 125)", exception(client.read_holding_registers(0, 126, slave=1)),
         "exception 03")
    reference = 40000 + holding
    client.write_register(holding - 1, 4321, slave=0)
    time.sleep(0.05)
    step(f"broadcast FC06 {reference} = 4321, read back from slave 1",
         values(client.read_holding_registers(holding - 1, 1, slave=1), "registers", 1), [4321])


def back_to_back(client, reads):
    """`reads` FC03 requests in a row; prints the answer rate and the time taken."""
    answered = 0
    start = time.monotonic()
    for _ in range(reads):
        response = client.read_holding_registers(0, 1, slave=1)
        if not isinstance(response, Exception) and response is not None and not response.isError():
            answered += 1
    took = time.monotonic() - start
    print(f"{'ok  ' if answered == reads else 'FAIL'} {reads} back-to-back FC03 reads: {answered} answered "
          f"({100.0 * answered / reads:.1f} %) in {took:.1f} s ({1000.0 * took / reads:.1f} ms each)", flush=True)
    if answered != reads:
        FAILED.append("back-to-back reads")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("port")
    parser.add_argument("--board", default="uno_slave", choices=["uno_slave", "dip_switch", "ascii", "configurable", "units", "boards"])
    parser.add_argument("--baud", type=int, default=19200)
    parser.add_argument("--parity", default="E", choices=["N", "E", "O"])
    parser.add_argument("--stop", type=int, default=1, choices=[1, 2])
    parser.add_argument("--control")
    parser.add_argument("--preset", type=int, default=0)
    parser.add_argument("--reads", type=int, default=0)
    parser.add_argument("--rounds", type=int, default=0)
    args = parser.parse_args()

    # Modbus ASCII: pymodbus's ASCII framer and the spec's 7 data bits (a Linux pty passes
    # the characters and keeps the baud rate, but shows 8 data bits and no parity).
    ascii = args.board == "ascii"
    framing = {"framer": ModbusAsciiFramer} if ascii else {}
    bytesize = 7 if ascii else 8
    client = ModbusSerialClient(args.port, baudrate=args.baud, parity=args.parity, stopbits=args.stop,
                                bytesize=bytesize, timeout=1, retries=0, broadcast_enable=True, strict=False,
                                **framing)
    if not client.connect():
        print(f"FAIL cannot open {args.port}")
        return 1
    print(f"pymodbus: {args.port} at {args.baud} {bytesize}{args.parity}{args.stop}, slave 1"
          f"{', ASCII' if ascii else ''}", flush=True)
    try:
        checks = {"uno_slave": uno_slave, "dip_switch": dip_switch, "ascii": ascii_board, "configurable": configurable,
                  "units": units, "boards": contract_boards}
        checks[args.board](client, args)
        if args.reads:
            back_to_back(client, args.reads)
    finally:
        client.close()
    if FAILED:
        print(f"{len(FAILED)} step(s) failed: {', '.join(FAILED)}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
