"""A Python Modbus RTU master polling a line of MiniMods, for the bench's peer scenario.

Two libraries, chosen with --lib:

  pymodbus       pymodbus's synchronous ModbusSerialClient, one client for the line, as
                 OpenPLC v4's Modbus master plugin drives a serial device;
  minimalmodbus  one minimalmodbus Instrument per unit, sharing the port.

Each cycle reads the discrete inputs X1..X10 of every unit (FC 2, what softplc's MiniMod driver
reads) and writes one output that changed (FC 5: Y1 of one unit, the units in turn, each write
the opposite of that unit's last). With --write-all the cycle instead writes every unit's Y1
each cycle whether it changed or not (FC 5 per unit), as a master that copies its whole output
image every cycle does.

The time of each cycle (from its first request to its last reply, perf_counter) is printed in
microseconds, one a line, after --warmup cycles; a failed transaction is printed as a line
"error: ..." on standard error and makes the exit status 1.
"""

import argparse
import sys
import time


# A Linux pty keeps no parity (it clears PARENB) and may refuse a port's second setting of it
# (EINVAL). Parity changes no timing in either library and the simulator follows only the
# master's baud rate on a pty, so the port is then opened 8N1.
PTY_PARITY = "N"
PTY_NOTE = "note: the port refused parity E (a pty carries no parity): opened 8N1"


def pymodbus_master(port, baud, timeout):
    from pymodbus.client import ModbusSerialClient
    from pymodbus import FramerType

    def client_with(parity):
        return ModbusSerialClient(
            port,
            framer=FramerType.RTU,
            baudrate=baud,
            bytesize=8,
            parity=parity,
            stopbits=1,
            timeout=timeout,
            retries=0,
        )

    client = client_with("E")
    if not client.connect():
        client = client_with(PTY_PARITY)
        if not client.connect():
            raise SystemExit(f"pymodbus cannot open {port}")
        print(PTY_NOTE, file=sys.stderr)

    def read(unit):
        r = client.read_discrete_inputs(0, count=10, device_id=unit)
        if r.isError():
            raise IOError(f"unit {unit}: FC 2: {r}")
        return r.bits[:10]

    def write(unit, on):
        r = client.write_coil(0, on, device_id=unit)
        if r.isError():
            raise IOError(f"unit {unit}: FC 5: {r}")

    return read, write


def minimalmodbus_master(port, baud, timeout, units):
    import termios

    import minimalmodbus
    import serial

    instruments = {}
    for unit in units:
        inst = minimalmodbus.Instrument(port, unit, mode=minimalmodbus.MODE_RTU)
        inst.serial.baudrate = baud
        inst.serial.bytesize = 8
        inst.serial.stopbits = 1
        try:
            inst.serial.parity = serial.PARITY_EVEN
        except (serial.SerialException, OSError, termios.error):
            inst.serial.parity = PTY_PARITY
            print(PTY_NOTE, file=sys.stderr)
        inst.serial.timeout = timeout
        inst.clear_buffers_before_each_transaction = True
        instruments[unit] = inst

    def read(unit):
        return instruments[unit].read_bits(0, 10, functioncode=2)

    def write(unit, on):
        instruments[unit].write_bit(0, 1 if on else 0, functioncode=5)

    return read, write


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--lib", choices=["pymodbus", "minimalmodbus"], required=True)
    p.add_argument("--port", required=True)
    p.add_argument("--baud", type=int, default=19200)
    p.add_argument("--units", default="1,2,3,4", help="unit addresses, comma-separated")
    p.add_argument("--cycles", type=int, default=100)
    p.add_argument("--warmup", type=int, default=2)
    p.add_argument("--timeout", type=float, default=0.5, help="response timeout, s")
    p.add_argument("--write-all", action="store_true")
    a = p.parse_args()
    units = [int(u) for u in a.units.split(",")]
    if a.lib == "pymodbus":
        read, write = pymodbus_master(a.port, a.baud, a.timeout)
    else:
        read, write = minimalmodbus_master(a.port, a.baud, a.timeout, units)

    outputs = {u: False for u in units}
    times = []
    errors = 0
    for k in range(a.warmup + a.cycles):
        t0 = time.perf_counter()
        try:
            for unit in units:
                read(unit)
            if a.write_all:
                changed = units[k % len(units)]
                outputs[changed] = not outputs[changed]
                for unit in units:
                    write(unit, outputs[unit])
            else:
                unit = units[k % len(units)]
                outputs[unit] = not outputs[unit]
                write(unit, outputs[unit])
        except Exception as e:  # a failed transaction: counted, the loop goes on
            errors += 1
            print(f"error: cycle {k}: {e}", file=sys.stderr)
            continue
        took = time.perf_counter() - t0
        if k >= a.warmup:
            times.append(took)
    for t in times:
        print(f"{t * 1e6:.1f}")
    sys.exit(1 if errors else 0)


if __name__ == "__main__":
    main()
