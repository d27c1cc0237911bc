"""How late the live view's messages reach a real viewer's page (prints figures; asserts nothing).

The simulator node (Table 1 drive, real time, ``live_view.enabled``) in its own process, once
per viewer cap (``live_view.max_rate_hz``, default runs: 0 = every message, and 100, the
default), each ``--repeat`` times. Foxglove Studio 1.48 in Debian's headless chromium
(test/studio_viewer/studio.mjs with config/foxglove_layout.json, the real-viewer test's page)
measures in the page, over ``--measure`` s: how long after its stamp each ``/joint_states``
message reached the page's thread (median and p95), how many came a second, and how many frames
the page drew a second. The baseline, in the same run and window: a WebSocket client of this
process (tornado, ``foxglove.websocket.v1``, subscribed to ``/joint_states`` only), which
shows what the server and the loopback add without a browser. The goal of the edges issue: a
median below 100 ms in the page at 1 kHz.

    .venv/bin/python benchmarks/bench_studio_lag.py [--caps 0,100] [--repeat 2] [--measure 6]

Needs node, the npm packages of test/studio_viewer (``npm ci --prefix test/studio_viewer``)
and a chromium (``ABB_ROS_CHROMIUM``, else ``chromium`` on PATH); says which is missing and
exits 0 without one.
"""

import argparse
import asyncio
import json
import os
import random
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

import numpy as np
from tornado.websocket import websocket_connect

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_live_view import free_port  # noqa: E402
from bench_simulator_node import stop_node  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
VIEWER = ROOT / 'test' / 'studio_viewer'
LAYOUT = ROOT / 'config' / 'foxglove_layout.json'
TOPIC = '/joint_states'


def why_not() -> tuple[str, list[str]]:
    """('', the command that runs studio.mjs) or (what is missing, [])."""
    node = shutil.which('node')
    chromium = os.environ.get('ABB_ROS_CHROMIUM') or shutil.which('chromium')
    if node is None:
        return 'node is not installed', []
    if not (VIEWER / 'node_modules' / '@foxglove' / 'studio-base').is_dir():
        return 'the npm packages of test/studio_viewer are not installed', []
    if chromium is None:
        return 'no chromium (apt-get install chromium, or set ABB_ROS_CHROMIUM)', []
    return '', [node, str(VIEWER / 'studio.mjs'), chromium]


class OwnClient(threading.Thread):
    """A WebSocket client on its own event loop: (arrival, lag) [s] of each TOPIC message."""

    def __init__(self, url: str):
        super().__init__(daemon=True)
        self.url, self.seen, self.error = url, [], None
        self.stop = threading.Event()

    def run(self):
        try:
            asyncio.run(self._receive())
        except Exception as error:   # reported with the figures, never hidden
            self.error = f'{type(error).__name__}: {error}'

    async def _receive(self):
        ws = await websocket_connect(self.url, subprotocols=['foxglove.websocket.v1'])
        while not self.stop.is_set():
            frame = await ws.read_message()
            if frame is None:
                return
            if isinstance(frame, str):
                message = json.loads(frame)
                for channel in message.get('channels', []) if message.get('op') == 'advertise' \
                        else []:
                    if channel['topic'] == TOPIC:
                        ws.write_message(json.dumps({'op': 'subscribe', 'subscriptions': [
                            {'id': 1, 'channelId': channel['id']}]}))
            elif frame[0] == 1:   # message data: op, subscription id, log time [ns], CDR
                now = time.time_ns()
                (log_time,) = struct.unpack_from('<Q', frame, 5)
                self.seen.append((now * 1e-9, (now - log_time) * 1e-9))
        ws.close()


def wait_for_port(port: int, proc: subprocess.Popen, timeout_s: float = 90.0) -> None:
    """Wait until the node's live view takes connections (its kernels may compile first)."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end and proc.poll() is None:
        try:
            socket.create_connection(('127.0.0.1', port), timeout=1).close()
            return
        except OSError:
            time.sleep(0.5)
    raise RuntimeError(f'the live view on port {port} did not open (node exit {proc.poll()})')


def one_run(command: list[str], cap: float, measure_s: float) -> dict:
    """Start the node at ``cap``, open Studio on its live view, and return what both saw."""
    node, script, chromium = command
    port = free_port()
    proc = subprocess.Popen(
        [sys.executable, '-m', 'abb_ros.nodes.simulator', '--ros-args',
         '-p', 'live_view.enabled:=true', '-p', f'live_view.port:={port}',
         '-p', f'live_view.max_rate_hz:={cap}'],
        cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_for_port(port, proc)
        url = f'ws://127.0.0.1:{port}'
        own = OwnClient(url)
        own.start()
        with tempfile.TemporaryDirectory(prefix='bench_studio_') as profile:
            options = dict(url=url, layout=str(LAYOUT), chromium=chromium, measure_s=measure_s,
                           timeout_s=120, profile=profile)
            started = time.time()
            out = subprocess.run([node, script, json.dumps(options)], capture_output=True,
                                 text=True, timeout=180)
        own.stop.set()   # ends at its next message
        own.join(timeout=10)
    finally:
        stop_node(proc)
    seen = json.loads(out.stdout)
    if 'failure' in seen:
        raise RuntimeError(f"Studio: {seen['failure']} (phases {seen['phases']})")
    window = seen['window']
    w1 = started + seen['phases']['measured']
    w0 = w1 - window['seconds']
    own_lags = np.array([lag for at, lag in own.seen if w0 <= at < w1]) * 1e3
    lag = window['lags'][TOPIC]
    return dict(page_median=lag['median'], page_p95=lag['p95'],
                rate=window['counts'][TOPIC] / window['seconds'],
                frames=window['frames'] / window['seconds'],
                own_median=float(np.median(own_lags)) if own_lags.size else float('nan'),
                own_p95=float(np.percentile(own_lags, 95)) if own_lags.size else float('nan'),
                own_error=own.error)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--caps', default='0,100', help='live_view.max_rate_hz values [Hz], comma '
                    'separated (0: every message)')
    ap.add_argument('--repeat', type=int, default=2, help='runs per cap')
    ap.add_argument('--measure', type=float, default=6.0, help="the page's window [s]")
    args = ap.parse_args()
    missing, command = why_not()
    print(f'viewer lag benchmark: Foxglove Studio 1.48 in headless chromium, {TOPIC} at 1 kHz, '
          f'{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}')
    if missing:
        print(f'  not run: {missing}')
        return
    print('  cap [Hz]  run   page lag median    p95   msg/s  frames/s   own client median'
          '    p95   page/own')
    for cap in (float(c) for c in args.caps.split(',')):
        for k in range(args.repeat):
            r = one_run(command, cap, args.measure)
            note = f'  own client: {r["own_error"]}' if r['own_error'] else ''
            print(f'  {cap:8g}  {k + 1:3d}   {r["page_median"]:10.0f} ms  {r["page_p95"]:5.0f} ms'
                  f'  {r["rate"]:6.0f}  {r["frames"]:8.1f}   {r["own_median"]:10.1f} ms'
                  f'  {r["own_p95"]:5.1f} ms  {r["page_median"] / r["own_median"]:8.1f}'
                  f'   load {os.getloadavg()[0]:.2f}{note}', flush=True)


if __name__ == '__main__':
    main()
