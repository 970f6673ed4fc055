#!/usr/bin/env python3
"""Two pymodbus TCP clients against examples/sixteen_each_tcp.rs built with feature
write-protect, whose allow-list lets 127.0.0.1 write and 127.0.0.2 only read: the reading
client's writes get exception 01 and change nothing, its reads are answered, the writing
client's writes are done.

    pymodbus_read_only_check.py check HOST PORT
        The reader connects from 127.0.0.2, the writer from 127.0.0.1 (both to HOST:PORT).
        One line per step; exits 1 if any went wrong.

Runs on pymodbus 3.0 (`slave=`) and 3.13 (`device_id=`).
"""

import argparse
import inspect
import sys

import pymodbus
from pymodbus.client import ModbusTcpClient

FAILED = []
# The keyword for the slave address: `device_id` since pymodbus 3.10, `slave` before.
UNIT = "device_id" if "device_id" in inspect.signature(ModbusTcpClient.read_holding_registers).parameters else "slave"


def step(name, got, want):
    """Prints one step of the transcript and remembers a mismatch."""
    ok = got == want
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {got}{'' if ok else f' (expected {want})'}", flush=True)
    if not ok:
        FAILED.append(name)


def outcome(response, field=None, count=0):
    """The values of a response, `written` for a write's echo, or what came instead."""
    if response is None or isinstance(response, Exception):
        return f"no answer ({response})"
    if response.isError():
        code = getattr(response, "exception_code", None)
        return f"exception {code:02d}" if code is not None else f"error {response}"
    if field is None:
        return "written"
    return [int(v) for v in getattr(response, field)[:count]]


def call(method, *args, **kwargs):
    """`method` for unit 1, an exception returned rather than raised."""
    try:
        return method(*args, **{UNIT: 1}, **kwargs)
    except Exception as error:  # noqa: BLE001 - the transcript shows it
        return error


def client(host, port, source):
    c = ModbusTcpClient(host, port=port, timeout=3, retries=1, source_address=(source, 0))
    if not c.connect():
        print(f"FAIL connect to {host}:{port} from {source}", flush=True)
        sys.exit(1)
    return c


def check(host, port):
    print(f"pymodbus {pymodbus.__version__}, {host}:{port}", flush=True)
    reader = client(host, port, "127.0.0.2")
    writer = client(host, port, "127.0.0.1")
    read = lambda who: outcome(call(who.read_holding_registers, 0, count=2), "registers", 2)  # noqa: E731
    before = read(reader)
    step("reader: FC 03 40001-40002", isinstance(before, list), True)
    step("reader: FC 06 40001", outcome(call(reader.write_register, 0, 0x0BAD)), "exception 01")
    step("reader: FC 16 40001-40002", outcome(call(reader.write_registers, 0, [0x0BAD, 0x0BAD])), "exception 01")
    step("reader: FC 05 00001", outcome(call(reader.write_coil, 0, True)), "exception 01")
    step("reader: FC 15 00001-00008", outcome(call(reader.write_coils, 0, [True] * 8)), "exception 01")
    step("reader: FC 03 40001-40002, unchanged", read(reader), before)
    step("reader: FC 01 00001-00008, unchanged", outcome(call(reader.read_coils, 0, count=8), "bits", 8), [0] * 8)
    step("writer: FC 16 40001-40002", outcome(call(writer.write_registers, 0, [0x1234, 0x5678])), "written")
    step("writer: FC 05 00001", outcome(call(writer.write_coil, 0, True)), "written")
    step("reader: FC 03 40001-40002, the writer's", read(reader), [0x1234, 0x5678])
    step("reader: FC 01 00001, the writer's", outcome(call(reader.read_coils, 0, count=1), "bits", 1), [1])
    reader.close()
    writer.close()
    print("all ok" if not FAILED else f"{len(FAILED)} failed: {', '.join(FAILED)}", flush=True)
    return 1 if FAILED else 0


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
