#!/usr/bin/env python3
"""The TCP master of examples/tcp_rtu.rs's interop test (tools/virtual-uno/tests/interop_two_ports.rs),
which polls the same model from the serial line with mbpoll at the same time.

    pymodbus_two_ports.py HOST PORT
        Loops on one connection until a line `stop` comes on standard input: writes the pair
        40003-40004 to (j, j) with FC 16, j = 1, 2, 3..., and reads 40001-40004 (FC 03) back,
        alternately. Checks every answer: no error, 40003-40004 the pair it wrote last (nobody
        else writes them), 40001-40002 a pair of equal words (the serial master writes them as
        one FC 16) that never goes back. Prints `seen K` each time the serial master's pair
        changes, then, at `stop`, one JSON line: requests, writes, errors (the first few), the
        last j written, the serial pairs seen. Then it answers, one JSON line each:
            `read`   40001-40002 and input registers 30001-30002 (writes so far, last writer);
            `write`  writes 40005 once (FC 16), then reads 30001-30002;
        and ends at end of input.

Runs on pymodbus 3.0 (`slave=`) and 3.13 (`device_id=`).
"""

import inspect
import json
import select
import sys

import pymodbus
from pymodbus.client import ModbusTcpClient

# The keyword for the unit id: `device_id` since pymodbus 3.10, `slave` before.
UNIT = "device_id" if "device_id" in inspect.signature(ModbusTcpClient.read_holding_registers).parameters else "slave"


def call(method, address, *args, **kwargs):
    """`method` for unit 1; (registers, None) or (None, what went wrong)."""
    try:
        response = method(address, *args, **{UNIT: 1}, **kwargs)
    except Exception as error:  # noqa: BLE001 - the transcript shows it
        return None, f"{type(error).__name__}: {error}"
    if response is None or response.isError():
        return None, f"{response}"
    return list(getattr(response, "registers", None) or []), None


def main():
    host, port = sys.argv[1], int(sys.argv[2])
    client = ModbusTcpClient(host, port=port, timeout=3, retries=0)
    if not client.connect():
        print(f"FAIL connect to {host}:{port}", flush=True)
        return 1
    print(f"pymodbus {pymodbus.__version__} on {host}:{port}", flush=True)
    requests, writes, errors, j, seen = 0, 0, [], 0, [0]

    def wrong(what):
        errors.append(f"request {requests}: {what}")
        print(f"FAIL {errors[-1]}", flush=True)

    while not select.select([sys.stdin], [], [], 0)[0]:
        requests += 1
        if requests % 2:
            _, error = call(client.write_registers, 2, [j + 1, j + 1])
            if error:
                wrong(f"write 40003-40004 = {j + 1}: {error}")
                continue
            j += 1
            writes += 1
            continue
        regs, error = call(client.read_holding_registers, 0, count=4)
        if error:
            wrong(f"read 40001-40004: {error}")
            continue
        if regs[2:4] != [j, j]:
            wrong(f"40003-40004 {regs[2:4]}, written {[j, j]}")
        if regs[0] != regs[1] or regs[0] < seen[-1]:
            wrong(f"40001-40002 {regs[0:2]} after {seen[-1]}")
        elif regs[0] != seen[-1]:
            seen.append(regs[0])
            print(f"seen {regs[0]}", flush=True)
    sys.stdin.readline()
    summary = {"requests": requests, "writes": writes, "errors": len(errors), "first_errors": errors[:5], "j": j}
    summary["seen"] = len(seen) - 1
    print(json.dumps(summary), flush=True)
    for line in sys.stdin:
        answer = {}
        if line.strip() == "write":
            _, answer["write_error"] = call(client.write_registers, 4, [0xBEEF])
        if line.strip() == "read":
            answer["holding"], answer["holding_error"] = call(client.read_holding_registers, 0, count=2)
        answer["input"], answer["input_error"] = call(client.read_input_registers, 0, count=2)
        print(json.dumps(answer), flush=True)
    client.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
