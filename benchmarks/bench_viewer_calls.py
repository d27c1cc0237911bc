"""How long a viewer's service call takes on the live view (prints figures; asserts nothing).

The simulator node (n = 10, 10 kHz / 1 kHz, real_time_factor 1, ``live_view.enabled``) runs
in its own process; a WebSocket client in this process (tornado, subprotocol
``foxglove.sdk.v1``) calls ``/abb_simulator/pause`` with ``data: false`` (the plant keeps
running: the answer is "running") CALLS times, one after the other, and takes the time from
sending the ``serviceCallRequest`` frame to receiving its ``serviceCallResponse``. The call
crosses to the node's thread, which carries the viewer's calls out every
``COMMAND_PERIOD_S`` (20 ms), so the answer is due within that period plus the callback.

    .venv/bin/python benchmarks/bench_viewer_calls.py [--calls 200]
"""

import argparse
import asyncio
import json
import os
import random
import socket
import struct
import sys
import time
from pathlib import Path

os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_simulator_node import start_node, stop_node  # noqa: E402

from abb_ros.nodes.simulator.live_view import COMMAND_PERIOD_S  # noqa: E402

CALL_REQUEST, CALL_RESPONSE = 2, 3   # binary opcodes of the Foxglove WebSocket protocol


def free_port() -> int:
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


async def connect(url: str, deadline_s: float):
    """Connect once the node's server listens (start-up compiles and imports first)."""
    from tornado.websocket import websocket_connect
    end = time.monotonic() + deadline_s
    while True:
        try:
            return await websocket_connect(url, subprotocols=['foxglove.sdk.v1'])
        except OSError:
            if time.monotonic() > end:
                raise
            await asyncio.sleep(0.2)


async def measure(url: str, calls: int) -> list[float]:
    """Round-trip times of ``calls`` service calls [s]."""
    from rclpy.serialization import serialize_message
    from std_srvs.srv import SetBool
    ws = await connect(url, 120.0)
    service_id = None
    while service_id is None:
        frame = await ws.read_message()
        if isinstance(frame, str) and json.loads(frame)['op'] == 'advertiseServices':
            service_id = next(s['id'] for s in json.loads(frame)['services']
                              if s['name'].endswith('/abb_simulator/pause'))
    payload = serialize_message(SetBool.Request(data=False))
    times = []
    for call_id in range(calls):
        frame = (struct.pack('<BIII', CALL_REQUEST, service_id, call_id, 3) + b'cdr'
                 + payload)
        start = time.perf_counter()
        await ws.write_message(frame, binary=True)
        while True:
            answer = await ws.read_message()
            if isinstance(answer, bytes) and answer[0] == CALL_RESPONSE:
                if struct.unpack_from('<I', answer, 5)[0] == call_id:
                    break
            elif isinstance(answer, str) and json.loads(answer)['op'] == 'serviceCallFailure':
                raise RuntimeError(answer)
        times.append(time.perf_counter() - start)
    ws.close()
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--calls', type=int, default=200)
    args = ap.parse_args()
    port = free_port()
    proc = start_node('/bench_calls', 'live_view.enabled:=true', f'live_view.port:={port}')
    try:
        from tornado.ioloop import IOLoop
        times = IOLoop().run_sync(lambda: measure(f'ws://127.0.0.1:{port}', args.calls),
                                  timeout=300)
    finally:
        code = stop_node(proc)
    ms = sorted(t * 1e3 for t in times)

    def pct(p):
        return ms[min(len(ms) - 1, int(p / 100 * len(ms)))]

    print(f'viewer service calls (/abb_simulator/pause data=false, {len(ms)} in a row, '
          f'simulator n = 10 at real_time_factor 1; the node carries calls out every '
          f'{COMMAND_PERIOD_S * 1e3:g} ms)')
    print(f'  p50 {pct(50):6.1f} ms   p90 {pct(90):6.1f} ms   p99 {pct(99):6.1f} ms   '
          f'max {ms[-1]:6.1f} ms')
    print(f'  simulator exit code {code}; {os.cpu_count()} CPUs, load average '
          f'{os.getloadavg()[0]:.2f} at the end')


if __name__ == '__main__':
    main()
