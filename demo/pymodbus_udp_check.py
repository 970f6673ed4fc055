#!/usr/bin/env python3
"""Polls examples/tcp_server.rs built with feature `udp` over Modbus UDP with pymodbus's UDP client.

    pymodbus_udp_check.py check HOST PORT
        pymodbus_tcp_check.py's checks over UDP, one datagram each way a request: every function
        code pymodbus sends (the map's eight with values checked, the others exception 01),
        exceptions 02 and 03, unit ids 1, 0, 247 and 0xFF; the write of 124 registers (an MBAP
        length of 255, no Modbus ADU) is dropped unanswered. One line per step; exits 1 if any
        went wrong.

    pymodbus_udp_check.py senders HOST PORT [--clients 4] [--rounds 50]
        CLIENTS UDP clients at once, each from a port of its own, in threads: each writes a holding
        register of its own (40001 + its number) and reads it back, ROUNDS times, back to back.
        An answer sent to the wrong sender fails a read back or times out. One JSON line:
        answered, failed (with the first errors); exits 1 if any failed.

    pymodbus_udp_check.py gateway HOST PORT
        examples/tcp_gateway.rs built with feature `udp`, demo/plant_slave.py as unit 3 on its
        line: unit 3's registers read and written through the gateway, its own registers at
        unit 255, exception 0A for unit 250. One line per step; exits 1 if any went wrong.

Written for pymodbus 3.0 (Debian 12's python3-pymodbus), as pymodbus_tcp_check.py.
"""

import argparse
import json
import sys
import threading

from pymodbus.client import ModbusUdpClient

import pymodbus_tcp_check as tcp


def senders(args):
    """CLIENTS clients, each writing and reading back its own register."""
    results = {"answered": 0, "failed": 0, "errors": []}
    lock = threading.Lock()

    def one(number):
        client = ModbusUdpClient(args.host, port=args.port, timeout=args.timeout, retries=0)
        client.connect()
        for r in range(args.rounds):
            value = number * 1000 + r
            errors = []
            written = client.write_register(number, value, slave=1)
            if written is None or isinstance(written, Exception) or written.isError():
                errors.append(f"client {number} round {r}: write: {written}")
            got = tcp.values(client.read_holding_registers(number, 1, slave=1), "registers", 1)
            if got != [value]:
                errors.append(f"client {number} round {r}: read back {got}, expected [{value}]")
            with lock:
                results["answered" if not errors else "failed"] += 1
                results["errors"].extend(errors[: max(0, 5 - len(results["errors"]))])
        client.close()

    threads = [threading.Thread(target=one, args=(n,)) for n in range(args.clients)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    print(json.dumps(results), flush=True)
    return results["failed"] == 0 and results["answered"] == args.clients * args.rounds


def gateway(client):
    """Unit 3 (demo/plant_slave.py: holding registers 0x0300 + i) behind the gateway."""
    tcp.step("FC03 unit 3 holding 0-3", tcp.values(client.read_holding_registers(0, 4, slave=3), "registers", 4),
             [0x300, 0x301, 0x302, 0x303])
    tcp.step("FC16 unit 3 holding 8-9 = 1000 2000", tcp.ok_or(client.write_registers(8, [1000, 2000], slave=3)), "ok")
    tcp.step("FC03 unit 3 holding 8-9 read back",
             tcp.values(client.read_holding_registers(8, 2, slave=3), "registers", 2), [1000, 2000])
    tcp.step("FC04 unit 3 input 0-1", tcp.values(client.read_input_registers(0, 2, slave=3), "registers", 2),
             [0x3000, 0x3001])
    tcp.step("FC04 unit 255: the gateway's own forwarded and answers counters",
             tcp.values(client.read_input_registers(0, 2, slave=255), "registers", 2),
             lambda got: isinstance(got, list) and got[0] >= 4 and got[1] >= 4)
    tcp.step("FC03 unit 250: no route", tcp.exception(client.read_holding_registers(0, 1, slave=250)), "exception 10")
    tcp.step("FC03 unit 3 holding 10 (past its map)",
             tcp.exception(client.read_holding_registers(10, 1, slave=3)), "exception 02")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=["check", "senders", "gateway"])
    parser.add_argument("host")
    parser.add_argument("port", type=int)
    parser.add_argument("--clients", type=int, default=4)
    parser.add_argument("--rounds", type=int, default=50)
    parser.add_argument("--timeout", type=float, default=3.0)
    args = parser.parse_args()
    if args.mode == "senders":
        return 0 if senders(args) else 1
    client = ModbusUdpClient(args.host, port=args.port, timeout=args.timeout, retries=0)
    client.connect()
    print(f"pymodbus UDP {args.host}:{args.port}, {args.mode}", flush=True)
    try:
        (gateway if args.mode == "gateway" else tcp.check)(client)
    finally:
        client.close()
    if tcp.FAILED:
        print(f"{len(tcp.FAILED)} step(s) failed: {', '.join(tcp.FAILED)}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
