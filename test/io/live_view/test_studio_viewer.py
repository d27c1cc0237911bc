"""The live view in a real viewer: Foxglove Studio 1.48 in a headless chromium.

test/studio_viewer/studio.mjs serves Studio's web bundle (npm ``@foxglove/studio-base``,
pinned by test/studio_viewer/package-lock.json) on a loopback page, opens it with the
repository's config/foxglove_layout.json on the simulator node's live view, and prints what the
page showed: the topic list, the Plot legends at two moments, the player problems, and the
counts, lags and animation frames a probe in the page measured (test/studio_viewer/probe.js).
Pass or fail comes from that text and those counts, never from how a panel looks; the
screenshots go to $ABB_ROS_ARTEFACTS (else pytest's tmp_path). Skips, saying why, without
node, the npm packages (``npm ci --prefix test/studio_viewer``; scripts/test runs it) or a
chromium (``ABB_ROS_CHROMIUM``, else ``chromium`` on PATH; .ci/run installs Debian's).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import threading
import time
from pathlib import Path

import pytest
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from abb_ros.io.live_view.rate_cap import DEFAULT_MAX_RATE_HZ

ROOT = Path(__file__).resolve().parents[3]
VIEWER_DIR = ROOT / 'test' / 'studio_viewer'
LAYOUT = ROOT / 'config' / 'foxglove_layout.json'
TIMEOUT_S = 150
PUBLISH_BUTTON = 'Publish speed command'
"""The button of the layout's Publish panel (``/spindle/speed_cmd``, ``{"data": 500.0}``)."""
TOPICS = ('/joint_states', '/deck/pose', '/spindle/speed', '/visualization/markers',
          '/deck/imu', '/deck/twist', '/diagnostics')


def studio_command(options: dict) -> list[str]:
    """The command that runs Studio in chromium (skip, saying why, where a part is missing)."""
    node = shutil.which('node')
    chromium = os.environ.get('ABB_ROS_CHROMIUM') or shutil.which('chromium')
    if node is None:
        pytest.skip('node is not installed: Foxglove Studio (npm) cannot be served')
    if not (VIEWER_DIR / 'node_modules' / '@foxglove' / 'studio-base').is_dir():
        pytest.skip('the npm packages of test/studio_viewer are not installed: '
                    'npm ci --prefix test/studio_viewer')
    if chromium is None:
        pytest.skip('no chromium (apt-get install chromium, or set ABB_ROS_CHROMIUM)')
    options['chromium'] = chromium
    return [node, str(VIEWER_DIR / 'studio.mjs'), json.dumps(options)]


def browser_processes(profile: Path) -> list[int]:
    """The pids of the processes (but this one) whose command line names chromium's
    ``profile`` directory."""
    pids, name, me = [], str(profile).encode(), str(os.getpid())
    for proc in Path('/proc').iterdir():
        try:
            named = proc.name.isdigit() and proc.name != me \
                and name in (proc / 'cmdline').read_bytes()
        except OSError:   # gone meanwhile, or not ours to read
            continue
        if named:
            pids.append(int(proc.name))
    return pids


def stop_browser(profile: Path, grace_s: float = 10.0) -> list[int]:
    """Wait up to ``grace_s`` for the browser of ``profile`` to exit, kill what is left (a node
    killed at the time-out leaves its chromium running, which would load the tests after it)
    and return the pids that were left."""
    end = time.monotonic() + grace_s
    while (left := browser_processes(profile)) and time.monotonic() < end:
        time.sleep(0.2)
    for pid in left:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    return left


@pytest.fixture(scope='module')
def studio(tmp_path_factory):
    """What Studio showed of the simulator node's live view (the JSON of studio.mjs)."""
    from test_simulator_node import Plant
    artefacts = Path(os.environ.get('ABB_ROS_ARTEFACTS') or tmp_path_factory.mktemp('studio'))
    artefacts.mkdir(parents=True, exist_ok=True)
    options = dict(layout=str(LAYOUT), artefacts=str(artefacts), measure_s=6,
                   timeout_s=TIMEOUT_S - 20, publish=PUBLISH_BUTTON,
                   parameter=dict(name='/abb_simulator.fault.speed_noise', value='40'),
                   profile=str(tmp_path_factory.mktemp('chromium_profile')))
    command = studio_command(options)
    plant = Plant(**{'live_view.enabled': True, 'live_view.port': 0})
    margin = plant.node.create_publisher(Float64, 'stability/margin', 10)   # as analysis does
    stop = threading.Event()

    def publish_margin():
        while not stop.wait(0.05):
            margin.publish(Float64(data=0.25))

    threading.Thread(target=publish_margin, daemon=True).start()
    try:
        options['url'] = plant.sim.live.view.url
        speeds = []
        plant.node.create_subscription(JointState, '/joint_states',
                                       lambda m: speeds.append(m.velocity[0]), 10)
        plant.spin_for(0.5)
        before = speeds[-1]
        out = subprocess.run([*command[:-1], json.dumps(options)], capture_output=True,
                             text=True, timeout=TIMEOUT_S)
        plant.spin_for(2.0)   # the command's ramp
        node = dict(speed_noise=plant.sim.get_parameter('fault.speed_noise').value,
                    speed_cmd=plant.sim.speed_cmd, speed_before=before, speed_after=speeds[-1])
    finally:
        stop.set()
        plant.close()
        left = stop_browser(Path(options['profile']))
    assert out.returncode == 0, out.stderr[-2000:]
    (artefacts / 'studio.stdout').write_text(out.stdout)   # kept as printed, if it fails
    seen = json.loads(out.stdout)
    seen['node'] = node
    seen['browser_left'] = left
    (artefacts / 'studio.json').write_text(json.dumps(seen, indent=1))
    assert 'failure' not in seen, (seen['failure'], seen['phases'])
    return seen


pytestmark = [pytest.mark.ros, pytest.mark.slow]


def test_studio_lists_every_topic(studio):
    text = studio['topics_text']
    for topic in TOPICS:
        assert f'{topic}\n' in text, topic
    assert 'sensor_msgs/msg/JointState' in text


def test_studio_receives_markers_for_the_3d_panel_at_their_rate(studio):
    window = studio['window']
    rate = window['counts']['/visualization/markers'] / window['seconds']
    assert rate > 5   # 20 Hz, the 3D panel's only topic
    assert not studio['errors']


def test_the_browser_exits_with_studio(studio):
    """Closing Studio ends every chromium process it started (none left to load what follows)."""
    assert studio['browser_left'] == []


def test_plot_legends_advance(studio):
    """The Plot panels show each series' newest value: they change while the drive runs."""
    before, after = studio['legend_before'], studio['legend_after']
    assert len(after) >= 7
    assert before != after


def test_studio_reports_no_player_problem_once_connected(studio):
    """pub:msgdef:/spindle/speed_cmd comes only in Studio's first state, before the channels
    (its Publish panel advertises as soon as the server can take messages): gone after."""
    assert studio['server_info']['metadata'] == {'ROS_DISTRO': 'jazzy'}
    assert 'No problems found' in studio['problems_text']


def test_a_parameter_set_in_the_parameters_panel_reaches_the_node(studio):
    [request] = studio['sent']['parameters']
    assert request['parameters'] == [{'name': '/abb_simulator.fault.speed_noise', 'value': 40}]
    assert studio['node']['speed_noise'] == 40.0


def test_the_publish_panels_speed_command_moves_the_plant(studio):
    assert studio['publish_button'] and studio['sent']['published'] == 1
    node = studio['node']
    assert node['speed_cmd'] == 500.0
    assert abs(node['speed_after'] - 500.0) < abs(node['speed_before'] - 500.0) - 10


def test_joint_states_reach_the_page_at_the_cap_and_promptly(studio):
    """The page's lag (its clock minus the wall-clock stamp) at the live view's cap of
    100 messages/s a topic: uncapped (3,000/s) it was 1-2 s (median) on 2 cores, and the
    page stalled past the time-out under load (docs/ros_api.md); the goal is 100 ms."""
    window = studio['window']
    lag = window['lags']['/joint_states']
    rate = window['counts']['/joint_states'] / window['seconds']
    stamped = window['stampRates']['/joint_states']
    print(f"studio: /joint_states {rate:.0f} Hz ({stamped:.1f} per second of stamps), lag "
          f"median {lag['median']:.0f} ms, p95 {lag['p95']:.0f} ms, "
          f"{window['frames'] / window['seconds']:.1f} frames/s")
    # the cap bounds messages per second of their stamps (uncapped: 1000); per wall second of
    # the page a late burst can put more in a window, so that rate is only bounded below
    assert 30 < rate and stamped <= DEFAULT_MAX_RATE_HZ * 1.01
    assert lag['median'] < 500
