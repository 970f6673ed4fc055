#!/usr/bin/env python3
"""pymodbus's serial RTU server as one slave among others on an RS-485 line (`make demo-plant`).

    python3 demo/plant_slave.py PORT [--unit 3] [--resync] [--turnaround-ms 0] [--seconds 0] [--debug]

One unit (3 by default), a stand-in for a device nobody here wrote (protocol addresses):
    holding registers 0-9   0x0300 + i
    input registers 0-3     0x3000 + i
    coils 0-7               off
    discrete inputs 0-7     on at odd addresses (0b1010_1010)
Every write it executes is printed on stdout (`plant_slave: unit 3 holding 0-1 <- [7, 8]`).
It serves PORT at 19200 until SIGTERM or --seconds, then exits 0.

pymodbus 3.0's RTU server finds a frame's end from its function code, never from the line's
silence (Serial Line v1.02 §2.5.1.1 ends a frame after 3.5 character times of it). On a line
with other slaves it hears their answers too, and takes each for the start of a request: an
answer shorter than the request of the same function code (`01 02 01 00 A1 88` is 6 bytes, a
request 8) waits for the next frame's bytes, the two fail their CRC together and the request
in the second is lost (and a Write Multiple Coils answer, read as a request, takes a CRC byte
for its byte count and swallows up to 255 bytes of what follows). A real receiver ends frames
by silence, which a pty's reader cannot time (the host's scheduling puts gaps of several ms
inside a frame). --resync takes instead the request that the bytes heard last form, its
length from its function code and its CRC right, and drops what came before; without it
pymodbus's framing is left as it ships. On a pty pymodbus answers a fraction of a millisecond
after a request's last byte, sooner than the 3.5 character times of silence a slave leaves
before it answers (2 ms at 19200; a USB adapter's latency hides this on a real line), and while
the master's driver may still be on: --turnaround-ms MS waits that long first. A pty carries
no parity bit: the line's 8E1 reaches it as 8N1 (see tools/virtual-uno/src/line.rs).

Unit-0 broadcasts are not taken (pymodbus 3.0 with broadcast_enable accepts every unit id,
and would answer 0B for the others' units: not on a shared line).

Debian: apt-get install python3-pymodbus python3-serial-asyncio (pymodbus 3.0).
"""

import argparse
import asyncio
import logging
import signal
import sys
import time

from pymodbus.datastore import (
    ModbusSequentialDataBlock,
    ModbusServerContext,
    ModbusSlaveContext,
)
from pymodbus.server import StartAsyncSerialServer
from pymodbus.transaction import ModbusRtuFramer
from pymodbus.utilities import checkCRC


class ResyncFramer(ModbusRtuFramer):
    """pymodbus's RTU framer, resynchronised on every byte (`RESYNC`): it is handed only whole
    requests with a right CRC, each taken when the bytes heard last form one (whatever came
    before them: another slave's answer, a request for another unit, is dropped); pymodbus then
    keeps those for its unit."""

    RESYNC = False
    DEBUG = False
    TURNAROUND = 0.0
    KEEP = 256  # the longest RTU frame: older bytes cannot belong to a request still coming

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._heard = b""

    def processIncomingPacket(self, data, callback, unit, **kwargs):  # pylint: disable=invalid-name
        if self.DEBUG:
            print(f"plant_slave: {time.monotonic():.4f} heard {data.hex(' ')}", file=sys.stderr, flush=True)
        if self.TURNAROUND:
            inner = callback

            def callback(request):  # pylint: disable=function-redefined
                asyncio.get_running_loop().call_later(self.TURNAROUND, inner, request)

        if not self.RESYNC:
            super().processIncomingPacket(data, callback, unit, **kwargs)
            return
        self._heard = (self._heard + data)[-self.KEEP :]
        for start in range(len(self._heard) - 3):
            frame = self._heard[start:]
            try:
                size = self.get_expected_response_length(frame)
            except Exception:  # pylint: disable=broad-except  # no request starts here
                continue
            if size == len(frame) and checkCRC(frame[:-2], int.from_bytes(frame[-2:], "big")):
                self._heard = b""
                self.resetFrame()
                super().processIncomingPacket(frame, callback, unit, **kwargs)
                return


class LoggedBlock(ModbusSequentialDataBlock):
    """A data block that prints each write."""

    def __init__(self, unit, table, address, values):
        super().__init__(address, values)
        self.label = f"unit {unit} {table}"

    def setValues(self, address, values):  # pylint: disable=invalid-name
        super().setValues(address, values)
        values = values if isinstance(values, list) else [values]
        values = [int(v) for v in values]
        print(f"plant_slave: {self.label} {address}-{address + len(values) - 1} <- {values}", flush=True)


async def serve(args):
    unit = ModbusSlaveContext(
        di=ModbusSequentialDataBlock(0, [bool(0b1010_1010 >> i & 1) for i in range(8)]),
        co=LoggedBlock(args.unit, "coils", 0, [False] * 8),
        hr=LoggedBlock(args.unit, "holding", 0, [0x0300 + i for i in range(10)]),
        ir=ModbusSequentialDataBlock(0, [0x3000 + i for i in range(4)]),
        zero_mode=True,  # pymodbus 3.0 otherwise adds 1 to every protocol address
    )
    ResyncFramer.RESYNC = args.resync
    ResyncFramer.TURNAROUND = args.turnaround_ms / 1000
    ResyncFramer.DEBUG = args.debug
    server = await StartAsyncSerialServer(
        context=ModbusServerContext(slaves={args.unit: unit}, single=False),
        framer=ResyncFramer,
        port=args.port,
        baudrate=19200,
        parity="N",
        bytesize=8,
        stopbits=1,
        timeout=0.005,
        broadcast_enable=False,
        defer_start=True,
    )
    await server.start()
    if server.transport is None:
        print(f"plant_slave: cannot open {args.port}", file=sys.stderr)
        return 1
    framing = "pymodbus's framing, resynchronised on each byte" if args.resync else "pymodbus's own framing"
    print(f"plant_slave: unit {args.unit} on {args.port} ({framing})", flush=True)
    stop = asyncio.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        asyncio.get_running_loop().add_signal_handler(sig, stop.set)
    try:
        await asyncio.wait_for(stop.wait(), args.seconds or None)
    except asyncio.TimeoutError:
        pass
    if not args.debug:  # stopping cancels the port's handler, which pymodbus logs as an error
        logging.getLogger("pymodbus.server.async_io").setLevel(logging.CRITICAL)
    await server.shutdown()
    return 0


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("port")
    parser.add_argument("--unit", type=int, default=3)
    parser.add_argument("--resync", action="store_true", help="take the request the last bytes heard form (see above)")
    parser.add_argument("--turnaround-ms", type=float, default=0.0, help="wait this long before answering (see above)")
    parser.add_argument("--seconds", type=float, default=0.0, help="serve this long (0: until SIGTERM)")
    parser.add_argument("--debug", action="store_true", help="pymodbus's debug log on stderr")
    args = parser.parse_args()
    logging.basicConfig(stream=sys.stderr, level=logging.DEBUG if args.debug else logging.WARNING)
    if not args.debug:  # pymodbus logs each exception reply it sends as an error
        logging.getLogger("pymodbus.pdu").setLevel(logging.CRITICAL)
    return asyncio.run(serve(args))


if __name__ == "__main__":
    sys.exit(main())
