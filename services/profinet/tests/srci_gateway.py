"""SRCI gateway for the PROFINET system test: the topology of the public SRCI TCP/IP bridge.

A PLC-side SRCI client (`rc plc`) connects over TCP and sends raw PLC->robot telegrams in
lockstep; this script is the IO-controller (profinet-py, used as a library, unmodified) of
the robot controller's PROFINET IO-device and puts each telegram into the SRCI module's
output data, then answers the client with the module's input data once the device has had
time to answer it (the cyclic round trip: the next output frame, the interpreter, the next
input frame).

Usage (in the PLC namespace, as root):
    python srci_gateway.py IFACE STATION GSDML --listen 127.0.0.1:5000 --cycle-ms 8 --size 256

Prints "srci layout: ..." (where the SRCI module's data sits in the output and input
frames), "gateway ready" once the AR is in data exchange, and "alarm: TYPE" for every alarm
of the device (profinet-py's AlarmListener acknowledges it).
"""

import argparse
import socket
import sys
import threading
import time

from profinet import rpc
from profinet.cyclic import CyclicController
from profinet.gsdml import load_gsdml
from profinet.rpc import IOCRSetup
from profinet.rt import build_iocr_configs
from profinet.util import ethernet_socket, get_mac, s2mac

SRCI_SLOT, SRCI_SUBSLOT = 1, 1


def connect(args):
    """Connects the IO AR as profinet-py's `cyclic` command does; returns the controller."""
    sock = ethernet_socket(args.interface, 3)
    src = get_mac(args.interface)
    info = rpc.get_station_info(sock, src, args.station)
    conn = rpc.RPCCon(info)
    conn.connect(src)
    slots = conn.discover_slots()
    io_slots = load_gsdml(args.gsdml).build_io_slots_from_device(slots)
    setup = IOCRSetup(
        slots=io_slots,
        send_clock_factor=32,
        reduction_ratio=args.cycle_ms,
        watchdog_factor=6,
        data_hold_factor=6,
    )
    conn.close()
    time.sleep(0.5)
    conn = rpc.RPCCon(info)
    result = conn.connect(src, iocr_setup=setup)
    if not result or not result.has_cyclic:
        sys.exit("cyclic IO not established")
    conn.prm_end()
    conn.application_ready()
    input_iocr, output_iocr = build_iocr_configs(
        slots=setup.slots,
        input_frame_id=result.input_frame_id,
        output_frame_id=result.output_frame_id,
        send_clock_factor=32,
        reduction_ratio=args.cycle_ms,
        watchdog_factor=6,
    )
    print_layout(output_iocr, input_iocr)
    cyclic = CyclicController(
        interface=args.interface,
        src_mac=src,
        dst_mac=s2mac(info.mac),
        input_iocr=input_iocr,
        output_iocr=output_iocr,
    )
    return conn, cyclic


def print_layout(output_iocr, input_iocr):
    """Prints where the SRCI module's data sits in the C_SDU of each direction, for captures:
    "srci layout: output frame 0xC000 offset 0 input frame 0xC001 offset 3"."""
    def place(iocr):
        srci = next(
            o
            for o in iocr.objects
            if (o.slot, o.subslot) == (SRCI_SLOT, SRCI_SUBSLOT) and o.data_length > 0
        )
        return f"frame 0x{iocr.frame_id:04X} offset {srci.frame_offset}"

    print(f"srci layout: output {place(output_iocr)} input {place(input_iocr)}", flush=True)


def serve(args, cyclic):
    """Forwards telegrams between one TCP client at a time and the SRCI module."""
    host, port = args.listen.rsplit(":", 1)
    fresh = threading.Condition()
    inputs = [0]

    def on_input(slot, subslot, _data):
        if (slot, subslot) == (SRCI_SLOT, SRCI_SUBSLOT):
            with fresh:
                inputs[0] += 1
                fresh.notify_all()

    cyclic.on_input(on_input)
    server = socket.create_server((host, int(port)))
    print("gateway ready", flush=True)
    while True:
        client, _ = server.accept()
        client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        with client:
            while True:
                telegram = b""
                while len(telegram) < args.size:
                    chunk = client.recv(args.size - len(telegram))
                    if not chunk:
                        break
                    telegram += chunk
                if len(telegram) < args.size:
                    break
                cyclic.set_output_data(SRCI_SLOT, SRCI_SUBSLOT, telegram)
                # The telegram leaves with the next output frame; the answer comes with an
                # input frame after the interpreter's turn: wait for the third input frame.
                with fresh:
                    target = inputs[0] + 3
                    fresh.wait_for(lambda: inputs[0] >= target, timeout=1.0)
                reply = cyclic.get_input_data(SRCI_SLOT, SRCI_SUBSLOT)
                client.sendall(reply if reply else bytes(args.size))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("interface")
    parser.add_argument("station")
    parser.add_argument("gsdml")
    parser.add_argument("--listen", default="127.0.0.1:5000")
    parser.add_argument("--cycle-ms", type=int, default=8)
    parser.add_argument("--size", type=int, default=256)
    args = parser.parse_args()
    conn, cyclic = connect(args)
    # The device's diagnosis alarms (robot error appears / disappears) must be
    # acknowledged, or the device gives the AR up after its RTA retries.
    alarms = conn.create_alarm_listener(args.interface)
    if alarms:
        alarms.add_callback(lambda alarm: print(f"alarm: {alarm.alarm_type_name}", flush=True))
        alarms.start()
    cyclic.start()
    try:
        serve(args, cyclic)
    except KeyboardInterrupt:
        pass
    finally:
        cyclic.stop()
        if alarms:
            alarms.stop()
        conn.close()


if __name__ == "__main__":
    main()
