#!/usr/bin/env python3
"""Polls examples/sixteen_each_tcp.rs built with feature rtu-over-tcp over Modbus RTU over TCP
with pymodbus's TCP client and its RTU framer (what Home Assistant's `type: rtuovertcp` does),
and checks every answer.

    pymodbus_rtu_over_tcp_check.py check HOST PORT
        Writes and reads back holding registers (FC 16, 06, 03) and coils (FC 15, 05, 01),
        reads discrete inputs and input registers (FC 02, 04), at slave addresses 1 and 17;
        exceptions 02 (a register past the map) and 01 (FC 08, serial line only). One line
        per step; exits 1 if any went wrong.

Runs on pymodbus 3.0 (`framer=ModbusRtuFramer`, `slave=`) and 3.13 (`framer=FramerType.RTU`,
`device_id=`).
"""

import argparse
import inspect
import sys

import pymodbus
from pymodbus.client import ModbusTcpClient

try:  # pymodbus >= 3.7
    from pymodbus import FramerType

    RTU = FramerType.RTU
except ImportError:
    from pymodbus.transaction import ModbusRtuFramer as RTU

try:
    from pymodbus.diag_message import ReturnQueryDataRequest
except ImportError:  # pymodbus >= 3.7
    from pymodbus.pdu.diag_message import ReturnQueryDataRequest

FAILED = []
# The keyword for the slave address: `device_id` since pymodbus 3.10, `slave` before.
UNIT = "device_id" if "device_id" in inspect.signature(ModbusTcpClient.read_holding_registers).parameters else "slave"


def step(name, got, want):
    """Prints one step of the transcript and remembers a mismatch."""
    ok = got == want
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {got}{'' if ok else f' (expected {want})'}", flush=True)
    if not ok:
        FAILED.append(name)


def values(response, field, count):
    """The bits or registers of a response, or a short description of what came instead."""
    if response is None or isinstance(response, Exception):
        return f"no answer ({response})"
    if response.isError():
        code = getattr(response, "exception_code", None)
        return f"exception {code:02d}" if code is not None else f"error {response}"
    return [int(v) for v in getattr(response, field)[:count]]


def written(response):
    """`written` for a write's echo, or a short description of what came instead."""
    return values(response, None, 0) if field_error(response) else "written"


def field_error(response):
    """True for no answer or an exception."""
    return response is None or isinstance(response, Exception) or response.isError()


def call(method, *args, unit, **kwargs):
    """`method` for slave address `unit`, an exception returned rather than raised."""
    try:
        return method(*args, **{UNIT: unit}, **kwargs)
    except Exception as error:  # noqa: BLE001 - the transcript shows it
        return error


def check(host, port):
    print(f"pymodbus {pymodbus.__version__}, RTU framer, {host}:{port}", flush=True)
    client = ModbusTcpClient(host, port=port, framer=RTU, timeout=3, retries=1)
    if not client.connect():
        print(f"FAIL connect to {host}:{port}")
        return 1
    for unit in (1, 17):
        regs = [unit, 0x1234, 0xBEEF, 7]
        step(f"{unit}: FC 16 40001-40004", written(call(client.write_registers, 0, regs, unit=unit)), "written")
        step(f"{unit}: FC 03 40001-40004", values(call(client.read_holding_registers, 0, count=4, unit=unit), "registers", 4), regs)
        step(f"{unit}: FC 06 40016", written(call(client.write_register, 15, 0xA5A5, unit=unit)), "written")
        step(f"{unit}: FC 03 40016", values(call(client.read_holding_registers, 15, count=1, unit=unit), "registers", 1), [0xA5A5])
        bits = [True, False, True, True, False, False, True, False, unit & 1 == 1]
        step(f"{unit}: FC 15 00001-00009", written(call(client.write_coils, 0, list(bits), unit=unit)), "written")
        step(f"{unit}: FC 01 00001-00009", values(call(client.read_coils, 0, count=9, unit=unit), "bits", 9), [int(b) for b in bits])
        step(f"{unit}: FC 05 00016", written(call(client.write_coil, 15, True, unit=unit)), "written")
        step(f"{unit}: FC 01 00016", values(call(client.read_coils, 15, count=1, unit=unit), "bits", 1), [1])
        step(f"{unit}: FC 02 10001-10016", values(call(client.read_discrete_inputs, 0, count=16, unit=unit), "bits", 16), [0] * 16)
        step(f"{unit}: FC 04 30001-30008", values(call(client.read_input_registers, 0, count=8, unit=unit), "registers", 8), [0] * 8)
    step("FC 03 40017 (past the map)", values(call(client.read_holding_registers, 16, count=1, unit=1), "registers", 1), "exception 02")
    step("FC 01 00017 (past the map)", values(call(client.read_coils, 16, count=1, unit=1), "bits", 1), "exception 02")
    if UNIT == "slave":
        diag = ReturnQueryDataRequest(0x1234, unit=1)
    else:
        diag = ReturnQueryDataRequest(message=b"\x12\x34", dev_id=1)
    step("FC 08 (serial line only)", values(execute(client, diag), "registers", 0), "exception 01")
    step("FC 03 after the exceptions", values(call(client.read_holding_registers, 0, count=1, unit=1), "registers", 1), [17])
    client.close()
    print("all ok" if not FAILED else f"{len(FAILED)} failed: {', '.join(FAILED)}", flush=True)
    return 1 if FAILED else 0


def execute(client, request):
    """Sends a request object as it is."""
    try:
        if "no_response_expected" in inspect.signature(client.execute).parameters:
            return client.execute(False, request)
        return client.execute(request)
    except Exception as error:  # noqa: BLE001 - the transcript shows it
        return error


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("check")
    run.add_argument("host")
    run.add_argument("port", type=int)
    args = parser.parse_args()
    sys.exit(check(args.host, args.port))


if __name__ == "__main__":
    main()
