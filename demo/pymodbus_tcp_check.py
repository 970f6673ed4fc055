#!/usr/bin/env python3
"""Polls examples/tcp_server.rs over Modbus TCP with pymodbus's TCP client and checks every answer.

    pymodbus_tcp_check.py check HOST PORT
        Every function code pymodbus 3.0 sends: the eight the map serves (01 02 03 04 05 06 15
        16) with values checked, the others (07 08 11 17 20 22 23 24 43) exception 01; exceptions
        02 and 03; unit ids 1, 0, 247 and 0xFF. One line per step; exits 1 if any went wrong.

    pymodbus_tcp_check.py poll HOST PORT [--seconds 10] [--interval 0] [--quiet-after S] [--timeout 3]
        One master on one connection reading 30001-30002 (the firmware's seconds and requests
        answered) for --seconds, back to back or --interval seconds apart; with --quiet-after it stops asking after S
        seconds and keeps the connection open, silent, until the end. Prints `first answer`
        when the first reply comes, then one JSON line: answered, failed (with the first
        errors), the seconds counter at the first and last answer, the slowest answer (ms),
        the connections it took. With --quiet-after it prints `quiet` when it stops asking.

Written for pymodbus 3.0 (Debian 12's python3-pymodbus); `slave=` is passed everywhere.
"""

import argparse
import json
import sys
import time

from pymodbus.client import ModbusTcpClient
from pymodbus.pdu import ExceptionResponse

try:
    from pymodbus.mei_message import ReadDeviceInformationRequest
    from pymodbus.other_message import ReadExceptionStatusRequest, GetCommEventCounterRequest, ReportSlaveIdRequest
    from pymodbus.diag_message import ReturnQueryDataRequest
    from pymodbus.file_message import ReadFileRecordRequest, FileRecord, ReadFifoQueueRequest
except ImportError:  # pymodbus >= 3.7
    from pymodbus.pdu.mei_message import ReadDeviceInformationRequest
    from pymodbus.pdu.other_message import ReadExceptionStatusRequest, GetCommEventCounterRequest, ReportSlaveIdRequest
    from pymodbus.pdu.diag_message import ReturnQueryDataRequest
    from pymodbus.pdu.file_message import ReadFileRecordRequest, FileRecord, ReadFifoQueueRequest

FAILED = []


def step(name, got, want):
    """Prints one step of the transcript and remembers a mismatch."""
    ok = got == want if not callable(want) else want(got)
    shown = "" if ok or callable(want) else f" (expected {want})"
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {got}{shown}", flush=True)
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


def ok_or(response):
    """`ok` for a normal answer to a write, else what came instead."""
    if response is None or isinstance(response, Exception):
        return f"no answer ({response})"
    if response.isError():
        return exception(response)
    return "ok"


def execute(client, request, unit=1):
    """A request pymodbus has no method for, sent to `unit`."""
    request.unit_id = request.slave_id = unit  # the name changed after pymodbus 3.0
    return client.execute(request)


def check(client):
    """examples/tcp_server.rs's map: 16 coils, 16 inputs, 8 input and 16 holding registers."""
    step("FC01 read coils 00001-00016", values(client.read_coils(0, 16, slave=1), "bits", 16), [0] * 16)
    step("FC05 write coil 00002 on", ok_or(client.write_coil(1, True, slave=1)), "ok")
    step("FC15 write coils 00003-00005 = 1 0 1", ok_or(client.write_coils(2, [True, False, True], slave=1)), "ok")
    step("FC15 write coils 00009-00016 = 1 1 1 1 0 0 0 1",
         ok_or(client.write_coils(8, [True] * 4 + [False] * 3 + [True], slave=1)), "ok")
    step("FC01 read back coils 00001-00016", values(client.read_coils(0, 16, slave=1), "bits", 16),
         [0, 1, 1, 0, 1, 0, 0, 0, 1, 1, 1, 1, 0, 0, 0, 1])
    step("FC05 write coil 00002 off", ok_or(client.write_coil(1, False, slave=1)), "ok")
    step("FC01 read back coils 00001-00003", values(client.read_coils(0, 3, slave=1), "bits", 3), [0, 0, 1])
    step("FC02 read discrete inputs 10001-10016", values(client.read_discrete_inputs(0, 16, slave=1), "bits", 16),
         [0] * 16)
    first = values(client.read_input_registers(0, 8, slave=1), "registers", 8)
    step("FC04 read input registers 30001-30008 (seconds, requests, zeros)", first,
         lambda got: isinstance(got, list) and got[2:] == [0] * 6)
    time.sleep(2.2)
    later = values(client.read_input_registers(0, 2, slave=1), "registers", 2)
    step("FC04 30001-30002 2.2 s later: the seconds went on (the main loop's delay(1000)), requests counted",
         later, lambda got: isinstance(got, list) and isinstance(first, list) and got[0] >= first[0] + 2
         and got[1] > first[1])
    step("FC03 read holding registers 40001-40016", values(client.read_holding_registers(0, 16, slave=1),
                                                              "registers", 16), [0] * 16)
    step("FC06 write register 40003 = 1234", ok_or(client.write_register(2, 1234, slave=1)), "ok")
    step("FC16 write registers 40004-40006 = 11 22 33", ok_or(client.write_registers(3, [11, 22, 33], slave=1)), "ok")
    step("FC16 write registers 40014-40016 = 65535 32768 1",
         ok_or(client.write_registers(13, [65535, 32768, 1], slave=1)), "ok")
    step("FC03 read back 40001-40016", values(client.read_holding_registers(0, 16, slave=1), "registers", 16),
         [0, 0, 1234, 11, 22, 33, 0, 0, 0, 0, 0, 0, 0, 65535, 32768, 1])

    # Unit ids: 0xFF the device itself, 0 too (§4.4.1.2); any other answered by default.
    for unit in (0xFF, 0, 1, 247):
        step(f"FC03 read 40003 as unit {unit}", values(client.read_holding_registers(2, 1, slave=unit),
                                                       "registers", 1), [1234])
    step("FC06 write 40007 = 7 as unit 0 (over TCP no broadcast: answered)",
         ok_or(client.write_register(6, 7, slave=0)), "ok")
    step("FC03 read back 40007 as unit 0xFF", values(client.read_holding_registers(6, 1, slave=0xFF),
                                                     "registers", 1), [7])

    # Exception 02: past the map, and a range that runs past its end.
    step("FC01 read coils 00001-00017", exception(client.read_coils(0, 17, slave=1)), "exception 02")
    step("FC02 read discrete input 10017", exception(client.read_discrete_inputs(16, 1, slave=1)), "exception 02")
    step("FC03 read 40017", exception(client.read_holding_registers(16, 1, slave=1)), "exception 02")
    step("FC03 read 40010-40026", exception(client.read_holding_registers(9, 17, slave=1)), "exception 02")
    step("FC04 read 30009", exception(client.read_input_registers(8, 1, slave=1)), "exception 02")
    step("FC05 write coil 00017", exception(client.write_coil(16, True, slave=1)), "exception 02")
    step("FC06 write 40017", exception(client.write_register(16, 1, slave=1)), "exception 02")
    step("FC15 write coils 00016-00017", exception(client.write_coils(15, [True, True], slave=1)), "exception 02")
    step("FC16 write 40016-40017", exception(client.write_registers(15, [1, 2], slave=1)), "exception 02")
    step("FC03 read 40016 after the refused writes (unchanged)",
         values(client.read_holding_registers(15, 1, slave=1), "registers", 1), [1])

    # Exception 03: quantities over the spec's limits (checked before the addresses).
    step("FC03 read 126 registers", exception(client.read_holding_registers(0, 126, slave=1)), "exception 03")
    step("FC04 read 126 registers", exception(client.read_input_registers(0, 126, slave=1)), "exception 03")
    step("FC01 read 2001 coils", exception(client.read_coils(0, 2001, slave=1)), "exception 03")
    step("FC02 read 2001 inputs", exception(client.read_discrete_inputs(0, 2001, slave=1)), "exception 03")
    step("FC03 read 0 registers", exception(client.read_holding_registers(0, 0, slave=1)), "exception 03")
    # 124 registers make a PDU of 254 bytes, an MBAP length of 255: no Modbus ADU (at most 260
    # bytes, length 254). pymodbus sends it; the server cannot follow the stream past it and
    # closes the connection without a reply, and pymodbus connects again for the next request.
    step("FC16 write 124 registers (length field 255): connection closed, no reply",
         exception(client.write_registers(0, [0] * 124, slave=1)),
         lambda got: got.startswith("no exception (Modbus Error: [Input/Output]"))
    step("FC15 write 1969 coils", exception(client.write_coils(0, [False] * 1969, slave=1)), "exception 03")

    # Exception 01: what pymodbus sends that the firmware does not serve (tcp_server is built
    # without the diagnostics and extra-fc features).
    step("FC07 read exception status", exception(execute(client, ReadExceptionStatusRequest())), "exception 01")
    step("FC08 diagnostics 00 return query data", exception(execute(client, ReturnQueryDataRequest(0x1234))),
         "exception 01")
    step("FC11 get comm event counter", exception(execute(client, GetCommEventCounterRequest())), "exception 01")
    step("FC17 report server id", exception(execute(client, ReportSlaveIdRequest())), "exception 01")
    step("FC20 read file record", exception(execute(client, ReadFileRecordRequest([FileRecord(file_number=1,
                                                                                             record_number=0,
                                                                                             record_length=1)]))),
         "exception 01")
    step("FC22 mask write register", exception(client.mask_write_register(0, 0xF2, 0x25, slave=1)), "exception 01")
    step("FC23 read/write registers", exception(client.readwrite_registers(read_address=0, read_count=1,
                                                                           write_address=0, write_registers=[1],
                                                                           slave=1)), "exception 01")
    step("FC24 read FIFO queue", exception(execute(client, ReadFifoQueueRequest(0))), "exception 01")
    step("FC43 read device identification", exception(execute(client, ReadDeviceInformationRequest())),
         "exception 01")
    step("FC03 read 40003 after the exceptions (the connection goes on)",
         values(client.read_holding_registers(2, 1, slave=1), "registers", 1), [1234])


def poll(client, args):
    """Back-to-back reads of 30001-30002 on one connection; a JSON line at the end."""
    answered, failed, errors = 0, 0, []
    first_seconds = last_seconds = None
    slowest = 0.0
    connections = 0
    sockets = set()
    quiet = False
    start = time.monotonic()
    while time.monotonic() - start < args.seconds:
        if args.quiet_after is not None and time.monotonic() - start >= args.quiet_after:
            if not quiet:
                quiet = True
                print("quiet", flush=True)
            time.sleep(0.05)
            continue
        sent = time.monotonic()
        try:
            response = client.read_input_registers(0, 2, slave=1)
        except Exception as error:  # pylint: disable=broad-except
            response = error
        took = time.monotonic() - sent
        if client.socket is not None and id(client.socket) not in sockets:
            sockets.add(id(client.socket))
            connections += 1
        if response is None or isinstance(response, Exception) or response.isError():
            failed += 1
            if len(errors) < 5:
                errors.append(f"{time.monotonic() - start:.2f} s: {response}")
            time.sleep(0.1)
            continue
        if answered == 0:
            print("first answer", flush=True)
        answered += 1
        slowest = max(slowest, took)
        if first_seconds is None:
            first_seconds = response.registers[0]
        last_seconds = response.registers[0]
        if args.interval:
            time.sleep(args.interval)
    print(json.dumps({"answered": answered, "failed": failed, "errors": errors, "first_seconds": first_seconds,
                      "last_seconds": last_seconds, "slowest_ms": round(slowest * 1000, 1),
                      "connections": connections, "took_s": round(time.monotonic() - start, 2)}), flush=True)
    return answered > 0 and failed == 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=["check", "poll"])
    parser.add_argument("host")
    parser.add_argument("port", type=int)
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--interval", type=float, default=0.0)
    parser.add_argument("--quiet-after", type=float)
    parser.add_argument("--timeout", type=float, default=3.0)
    args = parser.parse_args()

    client = ModbusTcpClient(args.host, port=args.port, timeout=args.timeout, retries=0)
    if args.mode == "poll":
        client.connect()
        try:
            return 0 if poll(client, args) else 1
        finally:
            client.close()
    if not client.connect():
        print(f"FAIL cannot connect to {args.host}:{args.port}")
        return 1
    print(f"pymodbus {args.host}:{args.port}, unit 1", flush=True)
    try:
        check(client)
    finally:
        client.close()
    if FAILED:
        print(f"{len(FAILED)} step(s) failed: {', '.join(FAILED)}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
