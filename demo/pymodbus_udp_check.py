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


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=["check", "senders"])
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
    print(f"pymodbus UDP {args.host}:{args.port}, unit 1", flush=True)
    try:
        tcp.check(client)
    finally:
        client.close()
    if tcp.FAILED:
        print(f"{len(tcp.FAILED)} step(s) failed: {', '.join(tcp.FAILED)}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
