#!/usr/bin/env python3
"""Polls examples/uno_slave on a (virtual) Uno with minimalmodbus and checks every answer.

Every function code the slave supports (01 02 03 04 05 06 15 16) through minimalmodbus's
public calls, exception 02 on a read and on a write, a broadcast write read back afterwards,
then N back-to-back FC03 reads with the answer rate.

    minimalmodbus_check.py PORT [--baud 19200] [--parity N] [--stop 1] [--control FIFO]
                           [--reads 300]

--control is the virtual Uno's command FIFO: the checks close a switch and turn a
potentiometer through it. Prints one line per step; exits 1 if any step went wrong.
Written for minimalmodbus 2.1 (demo/requirements.txt).

Parity: minimalmodbus opens the port at 8N1, and the parity is then set on
`instrument.serial`. On a Linux pty that second tcsetattr, whose only change is PARENB,
fails with termios.error (22, 'Invalid argument'): the pty drops PARENB and glibc reports
a call that changed nothing. Odd parity is accepted (PARODD sticks) but the virtual Uno
answers only none or even, so use parity N there; a real serial port takes E.
"""

import argparse
import sys
import time

import minimalmodbus
import serial

FAILED = []


def step(name, got, want):
    """Prints one step of the transcript and remembers a mismatch."""
    ok = got == want
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {got}" + ("" if ok else f" (expected {want})"), flush=True)
    if not ok:
        FAILED.append(name)


def answer(call):
    """What a call returned, `ok` for a write, or `exception NN` / `no answer (...)`."""
    try:
        result = call()
    except minimalmodbus.IllegalRequestError as error:
        codes = {"illegal function": 1, "illegal data address": 2, "illegal data value": 3}
        code = next((c for text, c in codes.items() if text in str(error)), None)
        return f"exception {code:02d}" if code else f"exception ({error})"
    except (minimalmodbus.ModbusException, serial.SerialException) as error:
        return f"no answer ({type(error).__name__}: {error})"
    return "ok" if result is None else result


def control(path, command):
    """Sends a command to the virtual Uno and gives the firmware's loop time to see it."""
    if path:
        with open(path, "w", encoding="ascii") as fifo:
            fifo.write(command + "\n")
        time.sleep(0.1)


def uno_slave(uno, args):
    """The classic demo's register map (examples/uno_slave.rs), one step per function code."""
    step("FC01 read coils 00001-00005", answer(lambda: uno.read_bits(0, 5, functioncode=1)), [0] * 5)
    control(args.control, "pin 6 0")
    step("FC02 read discrete inputs 10001-10004 (switch on pin 6 closed)",
         answer(lambda: uno.read_bits(0, 4, functioncode=2)), [1, 0, 0, 0])
    control(args.control, "adc A0 2500")
    step("FC04 read input register 30001 (A0 at 2.5 V)", answer(lambda: uno.read_register(0, functioncode=4)), 511)
    step("FC03 read holding registers 40001-40002 (defaults)",
         answer(lambda: uno.read_registers(0, 2, functioncode=3)), [500, 512])
    step("FC05 write coil 00002 on", answer(lambda: uno.write_bit(1, 1, functioncode=5)), "ok")
    step("FC15 write coils 00003-00005 = 1 0 1", answer(lambda: uno.write_bits(2, [1, 0, 1])), "ok")
    step("FC01 read back coils 00001-00005", answer(lambda: uno.read_bits(0, 5, functioncode=1)), [0, 1, 1, 0, 1])
    step("FC06 write register 40003 = 1234", answer(lambda: uno.write_register(2, 1234, functioncode=6)), "ok")
    step("FC16 write registers 40004-40006 = 11 22 33", answer(lambda: uno.write_registers(3, [11, 22, 33])), "ok")
    step("FC03 read back 40003-40006", answer(lambda: uno.read_registers(2, 4, functioncode=3)), [1234, 11, 22, 33])
    step("FC03 read 40011, past the last register", answer(lambda: uno.read_register(10, functioncode=3)),
         "exception 02")
    step("FC06 write 40011, past the last register",
         answer(lambda: uno.write_register(10, 1, functioncode=6)), "exception 02")
    uno.address = 0
    step("broadcast FC06 40010 = 4321 (no answer expected)",
         answer(lambda: uno.write_register(9, 4321, functioncode=6)), "ok")
    uno.address = 1
    step("FC03 read back 40010 from slave 1", answer(lambda: uno.read_register(9, functioncode=3)), 4321)


def back_to_back(uno, reads):
    """`reads` FC03 requests in a row; prints the answer rate and the time taken."""
    answered = 0
    start = time.monotonic()
    for _ in range(reads):
        if answer(lambda: uno.read_register(0, functioncode=3)) == 500:
            answered += 1
    took = time.monotonic() - start
    print(f"{'ok  ' if answered == reads else 'FAIL'} {reads} back-to-back FC03 reads: {answered} answered "
          f"({100.0 * answered / reads:.1f} %) in {took:.1f} s ({1000.0 * took / reads:.1f} ms each)", flush=True)
    if answered != reads:
        FAILED.append("back-to-back reads")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("port")
    parser.add_argument("--baud", type=int, default=19200)
    parser.add_argument("--parity", default="N", choices=["N", "E", "O"])
    parser.add_argument("--stop", type=int, default=1, choices=[1, 2])
    parser.add_argument("--control")
    parser.add_argument("--reads", type=int, default=0)
    args = parser.parse_args()

    # As the tutorials do it: open at minimalmodbus's default 19200 8N1, then set the line.
    try:
        uno = minimalmodbus.Instrument(args.port, 1)
        uno.serial.baudrate = args.baud
        uno.serial.parity = args.parity
        uno.serial.stopbits = args.stop
    except Exception as error:  # pyserial's own, or termios.error from tcsetattr
        print(f"FAIL cannot set {args.port} to {args.baud} 8{args.parity}{args.stop}: "
              f"{type(error).__name__}: {error}")
        return 1
    uno.serial.timeout = 1.0
    print(f"minimalmodbus {minimalmodbus.__version__}: {args.port} at {args.baud} 8{args.parity}{args.stop}, "
          "slave 1", flush=True)
    try:
        uno_slave(uno, args)
        if args.reads:
            back_to_back(uno, args.reads)
    finally:
        uno.serial.close()
    if FAILED:
        print(f"{len(FAILED)} step(s) failed: {', '.join(FAILED)}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
