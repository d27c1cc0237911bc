"""Cost of the live view (prints figures; asserts nothing).

1. Writing the five state topics of a sample at the node's pace (5000 msg/s, the node's CDR
   bytes), side by side on two servers: foxglove-sdk 0.30's (the live view's previous server,
   which takes only ``foxglove.sdk.v1``) and the live view's own (tornado; both subprotocols).
   Each with no viewer, and with Foxglove's own client (npm ``@foxglove/ws-protocol``,
   test/live_view_client/, run with node) subscribed to every channel from another process,
   offering ``foxglove.sdk.v1`` and, on the live view, its default ``foxglove.websocket.v1``:
   microseconds per write on the writing thread, CPU of this process over the window (the
   writer and the server's threads; the writer sleeps between periods), what the client
   received.
2. The simulator node at real time (real_time_factor 1, n = 10, 10 kHz / 1 kHz) in its own
   process for DURATION s, without and with ``live_view.enabled`` (``live_view.max_rate_hz``
   0: every message) and that client subscribed to everything: achieved real-time factor,
   overruns and slips (from /diagnostics; target 0 slips), CPU of the node process.

    .venv/bin/python benchmarks/bench_live_view.py [--messages 50000] [--duration 30]
"""

import argparse
import json
import os
import random
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_simulator_node import N_BALLS, Probe, start_node, stop_node  # noqa: E402

from abb_ros.io.live_view.server import LiveView  # noqa: E402
from abb_ros.io.wire import cdr  # noqa: E402
from abb_ros.model.dynamics.integrate import DEFAULT_DT, Simulation
from abb_ros.model.dynamics.spindle import SpindleMotor  # noqa: E402
from abb_ros.model.parameters.params import DriveParams  # noqa: E402
from abb_ros.model.sensors.imu import TYPICAL_IMU, ImuModel  # noqa: E402
from abb_ros.model.sensors.sampling import PlantSampler  # noqa: E402
from abb_ros.testing.procstat import cpu_seconds  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CLIENT = ROOT / 'test' / 'live_view_client'


def client_available() -> str:
    """Return why Foxglove's client cannot run here ('' when it can)."""
    if shutil.which('node') is None:
        return 'node is not installed'
    if not (CLIENT / 'node_modules' / '@foxglove' / 'ws-protocol').is_dir():
        return 'npm ci --prefix test/live_view_client first'
    return ''


def start_client(url: str, seconds: float, subprotocol: str | None = None) -> subprocess.Popen:
    """Foxglove's client subscribed to every channel of ``url`` for ``seconds``.

    ``subprotocol``: the one it offers (None: the client's default, foxglove.websocket.v1).
    """
    options = dict(messages=1, timeout_s=seconds, wait_for=['/never'])
    if subprotocol:
        options['subprotocol'] = subprotocol
    return subprocess.Popen(['node', str(CLIENT / 'client.mjs'), url, json.dumps(options)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def received(client: subprocess.Popen) -> int:
    out, _ = client.communicate(timeout=60)
    return sum(json.loads(out)['counts'].values()) if out else 0


def sample_messages(periods: int) -> list:
    """(topic, CDR bytes, stamp) of ``periods`` publish periods, as the node publishes them."""
    p = DriveParams(n=N_BALLS)
    sim = Simulation(p, 2.7 * p.omega0, DEFAULT_DT, spindle=SpindleMotor(2000.0, 0.05))
    steps = int(round(1e-3 / DEFAULT_DT))
    sampler = PlantSampler(sim, ImuModel(TYPICAL_IMU), steps, steps)
    out = []
    for _ in range(periods):
        for sample in sampler.next_period():
            stamp, encoded = cdr.sample_cdr(sample, int(DEFAULT_DT * 1e9), TYPICAL_IMU, 0, True)
            out.extend((topic, data, stamp) for topic, data in encoded)
    return out


def time_writes(view, messages: list, rate_hz: float) -> tuple[float, float]:
    """Write ``messages`` at ``rate_hz`` (five per millisecond, as the node publishes them).

    Returns (seconds per write on this thread, CPU of this process as a fraction of a core).
    """
    spent, start = 0.0, time.perf_counter()
    cpu0 = time.process_time()
    per_period = 5
    for k in range(0, len(messages), per_period):
        due = start + k / rate_hz
        ahead = due - time.perf_counter()
        if ahead > 0:
            time.sleep(ahead)
        t0 = time.perf_counter()
        for topic, data, stamp in messages[k:k + per_period]:
            view.write(topic, data, stamp)
        spent += time.perf_counter() - t0
    wall = time.perf_counter() - start
    return spent / len(messages), (time.process_time() - cpu0) / wall


class SdkView:
    """foxglove-sdk 0.30's server with the live view's channels: the previous path."""

    def __init__(self):
        import foxglove
        self._foxglove = foxglove
        self._context = foxglove.Context()
        self.server = foxglove.start_server(name='abb_ros', host='127.0.0.1', port=0,
                                            supported_encodings=['cdr'],
                                            context=self._context)
        self.url = f'ws://127.0.0.1:{self.server.port}'
        self._channels = {}

    def add_topic(self, topic: str, type_name: str) -> None:
        from abb_ros.io.wire import msgdefs
        name = '/' + topic.lstrip('/')
        full = msgdefs.normalize_type(type_name)
        schema = self._foxglove.Schema(name=full, encoding='ros2msg',
                                       data=msgdefs.full_text(full).encode())
        self._channels[topic] = self._foxglove.Channel(
            name, schema=schema, message_encoding='cdr', context=self._context)

    def write(self, topic: str, data: bytes, stamp_ns: int) -> None:
        self._channels[topic].log(data, log_time=stamp_ns)

    def close(self) -> None:
        self.server.stop()


STATE_TYPES = {'joint_states': 'sensor_msgs/msg/JointState',
               'deck/pose': 'geometry_msgs/msg/PoseStamped',
               'deck/twist': 'geometry_msgs/msg/TwistStamped',
               'deck/imu': 'sensor_msgs/msg/Imu', '/clock': 'rosgraph_msgs/msg/Clock'}
RATE_HZ = 5000.0
"""Messages per second of the node's five 1 kHz topics."""


def bench_writes(count: int, why_not: str) -> None:
    messages = sample_messages(count // 5 + 1)[:count]
    seconds = len(messages) / RATE_HZ
    print(f'\n[writing {len(messages)} messages of the five state topics at {RATE_HZ:.0f} msg/s, '
          f'{seconds:.0f} s per case]')
    print('  server            viewer                          us/write  CPU of the process'
          '   received  dropped  load')
    cases = [('foxglove-sdk 0.30', SdkView, [None, 'foxglove.sdk.v1']),
             ('live view', lambda: LiveView(port=0),
              [None, 'foxglove.websocket.v1', 'foxglove.sdk.v1'])]
    for server, make, viewers in cases:
        for subprotocol in viewers:
            view = make()
            try:
                for topic, type_name in STATE_TYPES.items():
                    view.add_topic(topic, type_name)
                time_writes(view, messages[:1000], RATE_HZ)   # warm
                client = None
                if subprotocol and not why_not:
                    client = start_client(view.url, seconds + 8.0, subprotocol)
                    time.sleep(2.0)   # connected and subscribed
                elif subprotocol:
                    print(f'  {server:17s} {subprotocol}: skipped ({why_not})')
                    continue
                per, cpu = time_writes(view, messages, RATE_HZ)
                got = f'{received(client):6d}' if client is not None else '     -'
                label = f'client, {subprotocol}' if subprotocol else 'none'
                dropped = getattr(view, 'dropped', None)   # foxglove-sdk does not count them
                dropped = '      -' if dropped is None else f'{dropped:7d}'
                print(f'  {server:17s} {label:30s} {1e6 * per:8.2f}  {100 * cpu:6.1f} % of a core'
                      f'   {got}  {dropped}  {os.getloadavg()[0]:.2f}')
            finally:
                view.close()


def free_port() -> int:
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def measure_node(ns: str, seconds: float, live: bool, why_not: str) -> dict:
    port = free_port()
    params = ['real_time_factor:=1.0']
    if live:
        # every message, as the first part writes them (the viewers' default cap would send
        # 100 a second of each topic)
        params += ['live_view.enabled:=true', f'live_view.port:={port}',
                   'live_view.max_rate_hz:=0']
    proc = start_node(ns, *params)
    probe = Probe(ns, False)
    client = None
    try:
        probe.wait_diag()
        if live and not why_not:   # the client's default subprotocol, foxglove.websocket.v1
            client = start_client(f'ws://127.0.0.1:{port}', seconds + 6.0)
        probe.spin_for(3.0)   # start-up transients, the client connected
        d0_t, d0 = probe.diag
        c0, w0 = cpu_seconds(proc.pid), time.perf_counter()
        probe.spin_for(seconds)
        c1, w1 = cpu_seconds(proc.pid), time.perf_counter()
        d1_t, d1 = probe.diag
    finally:
        rc = stop_node(proc)
        probe.close()
    got = received(client) if client is not None else None
    return dict(rtf=(float(d1['sim_time']) - float(d0['sim_time'])) / (d1_t - d0_t),
                overruns=int(d1['overruns']) - int(d0['overruns']),
                slips=int(d1['slips']) - int(d0['slips']), cpu=(c1 - c0) / (w1 - w0),
                window=w1 - w0, exit_code=rc, received=got)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--messages', type=int, default=50000, help='messages timed per case')
    ap.add_argument('--duration', type=float, default=30.0, help='node window per case [s]')
    args = ap.parse_args()
    why_not = client_available()
    print(f'live view benchmark: n = {N_BALLS}, load average {os.getloadavg()[0]:.2f} on '
          f'{os.cpu_count()} cores')
    bench_writes(args.messages, why_not)
    print(f'\n[simulator node, real time, {args.duration:.0f} s window each]')
    print('  live view                  rtf      overruns  slips  CPU of the node  exit')
    for label, live in (('off', False), ('on, client subscribed', True)):
        r = measure_node(f'/bench_live_{int(live)}', args.duration, live, why_not)
        print(f'  {label:24s} {r["rtf"]:.4f}  {r["overruns"]:8d}  {r["slips"]:5d}  '
              f'{100 * r["cpu"]:6.1f} % of one core  {r["exit_code"]}   load '
              f'{os.getloadavg()[0]:.2f}')
        if r['received'] is not None:
            print(f'    the client received {r["received"]} messages '
                  f'({r["received"] / (r["window"] + 3.0):.0f}/s while the node ran)')


if __name__ == '__main__':
    main()
