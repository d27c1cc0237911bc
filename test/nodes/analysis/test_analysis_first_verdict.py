"""Until its first verdict the analysis node says why it has none (STALE), then answers.

The analysis node runs as a subprocess with a large table (slow first verdict). The test
publishes joint_states_throttle (what the node reads) at a fixed speed only once it has
received a first status, so on a loaded machine a slow DDS discovery cannot let the verdict
overtake every earlier status.
Every status before the first stability/margin must be STALE and name the reason (the table
being computed, or no joint_states_throttle yet); the first verdict must come, with a margin.
"""

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from sensor_msgs.msg import JointState
from test_analysis_node import OMEGA0, Probe

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[3]
TABLE_POINTS = 3000   # ten times the default: the first table takes seconds


def test_statuses_before_the_first_verdict_are_stale_and_say_why(tmp_path):
    log = open(tmp_path / 'analysis.log', 'w+')
    proc = subprocess.Popen(
        [sys.executable, '-m', 'abb_ros.nodes.analysis', '--ros-args', '-p',
         f'table_points:={TABLE_POINTS}'],
        cwd=ROOT, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
    probe = Probe()
    margin_at = []
    try:
        pub = probe.node.create_publisher(JointState, 'joint_states_throttle', 10)
        msg = JointState(name=['spindle', 'ball_1', 'ball_2'], position=[0.0, 1.0, -1.0],
                         velocity=[2.7 * OMEGA0, 0.0, 0.0])
        probe.wait_for(lambda: probe.statuses, 60.0, 'a first status of the analysis node')
        first_publish_at = time.monotonic()   # no verdict can come before the first speed
        deadline = time.monotonic() + 120
        while not probe.margins:
            assert time.monotonic() < deadline, 'no verdict within 120 s'
            assert proc.poll() is None, 'the analysis node exited'
            pub.publish(msg)
            if probe.margins:
                break
            time.sleep(0.02)
        margin_at.append(time.monotonic())
        probe.wait_for(lambda: any(s[2] != DiagnosticStatus.STALE for s in probe.statuses),
                       10.0, 'a verdict status')
    finally:
        probe.close()
        proc.send_signal(signal.SIGINT)
        code = proc.wait(timeout=30)
        log.seek(0)
        output = log.read()
        log.close()
    assert code == 0, output
    # Before the first verdict: what came before the first joint_states, and what came well
    # before the first margin (a verdict's status arrives with its margin). On a fast
    # machine the table may be ready before discovery ends, so the verdict follows the
    # first joint_states at once.
    before = [s for s in probe.statuses
              if s[0] < max(first_publish_at, margin_at[0] - 0.05)]
    assert before, 'no status before the first verdict'
    assert all(s[2] == DiagnosticStatus.STALE for s in before), [s[2:4] for s in before]
    reasons = ('computing the stability table', 'no joint_states_throttle yet')
    assert all(any(r in s[3] for r in reasons) for s in before), sorted({s[3] for s in before})
    computing = [s for s in before if 'no verdict yet' in s[3]]
    assert all('stability table' in s[3] for s in computing), [s[3] for s in computing]
    # the first status came before any joint_states: it is STALE whatever the table's state
    assert probe.statuses[0][2] == DiagnosticStatus.STALE
    first_verdict = next(s for s in probe.statuses if s[2] != DiagnosticStatus.STALE)
    assert first_verdict[2] in (DiagnosticStatus.OK, DiagnosticStatus.WARN,
                                DiagnosticStatus.ERROR)
