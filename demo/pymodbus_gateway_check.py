#!/usr/bin/env python3
"""pymodbus's TCP client through a Modbus TCP to RTU gateway to demo/plant_slave.py's unit.

    python3 demo/pymodbus_gateway_check.py HOST PORT [--unit 3]

Every function code on the slave behind the gateway (demo/plant_slave.py's map), the slave's
own exception passed through, 0A for units 248-254 (not routed), 0B for a unit nobody answers,
a read to unit 0 (0A) and a padded request (03, never on the line), the gateway's registers and
the slaves' health at unit 255, then clients that go away mid-request (half a request
then a close, a whole request then a close before the answer, a request then an RST) and a
client after them still answered. One line per step, then
`pymodbus_gateway_check: N steps, M failed`; exits 1 if any failed.

Written for pymodbus 3.0 (Debian 12's python3-pymodbus).
"""

import argparse
import socket
import struct
import sys
import time

from pymodbus.client import ModbusTcpClient

RESULTS = []


def step(name, got, want):
    ok = got == want
    RESULTS.append(ok)
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {got}" + ("" if ok else f" (expected {want})"), flush=True)


def answer(reply, field):
    code = getattr(reply, "exception_code", None)
    if code is not None:
        return f"exception {code:02X}"
    if reply is None or not hasattr(reply, field):
        return f"no answer ({reply})"
    return list(getattr(reply, field))


def ok_or(reply):
    code = getattr(reply, "exception_code", None)
    if code is not None:
        return f"exception {code:02X}"
    return "ok" if reply is not None and not reply.isError() else f"no answer ({reply})"


def adu(tid, unit, pdu):
    return struct.pack(">HHHB", tid, 0, len(pdu) + 1, unit) + pdu


def counters(client):
    """The gateway's registers 40001-40009 at unit 255: its counters, the connections waiting."""
    return answer(client.read_holding_registers(0, 9, slave=255), "registers")


def health(client, slave):
    """What the gateway knows of `slave`: answers, misses, misses in a row, down (registers 1000 + 4n)."""
    return answer(client.read_holding_registers(1000 + 4 * slave, 4, slave=255), "registers")


def check(host, port, unit):
    client = ModbusTcpClient(host, port=port, timeout=3)
    client.connect()
    step(f"FC03 unit {unit} 40001-40004", answer(client.read_holding_registers(0, 4, slave=unit), "registers"),
         [0x300, 0x301, 0x302, 0x303])
    step(f"FC06 unit {unit} 40005 = 1234", ok_or(client.write_register(4, 1234, slave=unit)), "ok")
    step(f"FC16 unit {unit} 40006-40007 = 11 22", ok_or(client.write_registers(5, [11, 22], slave=unit)), "ok")
    step(f"FC03 unit {unit} 40005-40007 read back", answer(client.read_holding_registers(4, 3, slave=unit), "registers"),
         [1234, 11, 22])
    step(f"FC04 unit {unit} 30001-30004", answer(client.read_input_registers(0, 4, slave=unit), "registers"),
         [0x3000, 0x3001, 0x3002, 0x3003])
    step(f"FC05 unit {unit} coil 00002 on", ok_or(client.write_coil(1, True, slave=unit)), "ok")
    step(f"FC15 unit {unit} coils 00005-00007 = 1 0 1",
         ok_or(client.write_coils(4, [True, False, True], slave=unit)), "ok")
    step(f"FC01 unit {unit} coils 00001-00008", answer(client.read_coils(0, 8, slave=unit), "bits"),
         [False, True, False, False, True, False, True, False])
    step(f"FC02 unit {unit} inputs 10001-10008", answer(client.read_discrete_inputs(0, 8, slave=unit), "bits"),
         [bool(0b1010_1010 >> i & 1) for i in range(8)])
    step(f"FC03 unit {unit} 40011, past its map: the slave's exception 02 passed through",
         answer(client.read_holding_registers(10, 1, slave=unit), "registers"), "exception 02")
    before = counters(client)
    for other in (248, 250, 254):
        step(f"FC03 unit {other}: not routed, 0A", answer(client.read_holding_registers(0, 1, slave=other), "registers"),
             "exception 0A")
    step("FC03 unit 0: a read cannot be a broadcast, 0A at once",
         answer(client.read_holding_registers(0, 1, slave=0), "registers"), "exception 0A")
    padded = adu(0x7A00, unit, bytes([0x03, 0x00, 0x00, 0x00, 0x04, 0xAA, 0xBB]))
    with socket.create_connection((host, port)) as s:
        s.sendall(padded)
        step(f"FC03 unit {unit} with two bytes of padding: 03 from the gateway, as the slave would answer",
             s.recv(64), adu(0x7A00, unit, bytes([0x83, 0x03])))
    for n in (1, 2, 3):
        step(f"FC03 unit 9: nobody on the line answers, 0B after the tries ({n} of 3)",
             answer(client.read_holding_registers(0, 1, slave=9), "registers"), "exception 0B")
    started = time.monotonic()
    step("FC03 unit 9 again: 0B at once (down after 3 misses in a row, until rechecked)",
         answer(client.read_holding_registers(0, 1, slave=9), "registers"), "exception 0B")
    step("  ... in less than 100 ms (no line timeout)", time.monotonic() - started < 0.1, True)
    after = counters(client)
    if isinstance(before, list) and isinstance(after, list):
        step("unit 255: 0A sent (register 3) up by 4", after[3] - before[3], 4)
        step("unit 255: 0B sent (register 4) up by 4", after[4] - before[4], 4)
        step("unit 255: malformed requests (register 7) up by 1", after[7] - before[7], 1)
        step("unit 255: slave 9's health (answers, misses, in a row, down)", health(client, 9), [0, 3, 3, 1])
        step(f"unit 255: slave {unit}'s health: no miss, not down", health(client, unit)[1:], [0, 0, 0])
    else:
        step("unit 255: the gateway's registers", (before, after), "registers")
    client.close()

    # Clients that go away mid-request.
    request = adu(0x7A01, unit, bytes([0x03, 0x00, 0x00, 0x00, 0x01]))
    with socket.create_connection((host, port)) as s:
        s.sendall(request[:5])  # half an MBAP header
    with socket.create_connection((host, port)) as s:
        s.sendall(request[:9])  # header and part of the PDU
    with socket.create_connection((host, port)) as s:
        s.sendall(request)  # a whole request, then a FIN: the gateway answers, then closes
    s = socket.create_connection((host, port))
    s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    s.sendall(adu(0x7A02, unit, bytes([0x03, 0x00, 0x01, 0x00, 0x01])))
    s.close()  # an RST
    time.sleep(0.5)
    client = ModbusTcpClient(host, port=port, timeout=3)
    client.connect()
    step(f"after four clients went away mid-request: FC03 unit {unit} 40001",
         answer(client.read_holding_registers(0, 1, slave=unit), "registers"), [0x300])
    final = counters(client)
    if isinstance(after, list) and isinstance(final, list):
        # The FIN's client still gets its answer; the RST's is dropped if its request was
        # already on the line, else its request goes with the reset connection.
        step("unit 255: answers whose connection had closed (register 6) up by 0 or 1", final[6] - after[6] in (0, 1),
             True)
        step("unit 255: no connection waiting (register 8)", final[8], 0)
    client.close()
    failed = RESULTS.count(False)
    print(f"pymodbus_gateway_check: {len(RESULTS)} steps, {failed} failed", flush=True)
    return 1 if failed else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("host")
    parser.add_argument("port", type=int)
    parser.add_argument("--unit", type=int, default=3)
    args = parser.parse_args()
    return check(args.host, args.port, args.unit)


if __name__ == "__main__":
    sys.exit(main())
