"""realtime_priority: the integrating thread runs under SCHED_FIFO while paced, or says why not.

The simulator runs as its own process (its thread ``abb_plant`` integrates); the test reads
the policy the kernel reports for each thread of the process (os.sched_getscheduler) and the
``scheduling`` value of the node's /diagnostics status, and checks that they agree and that
only the plant's thread changed policy. Whether the system
grants SCHED_FIFO depends on the machine (CAP_SYS_NICE, rtprio limits): both outcomes are
valid, a disagreement or a crash is not.
"""

import os
import resource
import shutil
import signal
import subprocess
import sys
import time

import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

pytestmark = [pytest.mark.ros, pytest.mark.slow]   # a node process per test, ~5 s each

DEADLINE_S = 60.0   # includes the node's start-up on a loaded machine


def thread_policies(pid: int) -> dict[str, tuple[int, int]]:
    """{thread name (kernel's): (policy, priority)} of process ``pid``; a name shared by
    several threads (Fast DDS's, Python's) keeps the last."""
    out = {}
    for tid in os.listdir(f'/proc/{pid}/task'):
        try:
            with open(f'/proc/{pid}/task/{tid}/comm') as f:
                name = f.read().strip()
            out[name] = os.sched_getscheduler(int(tid)), os.sched_getparam(int(tid)).sched_priority
        except (FileNotFoundError, ProcessLookupError):
            pass
    return out


def run_simulator(tmp_path, *params, without_cap_sys_nice=False):
    """(scheduling value of the first simulation status, kernel policy of the node's plant
    thread then, the node's log, exit code after SIGINT, the policies of its threads)."""
    args = [sys.executable, '-m', 'abb_ros.nodes.simulator', '--ros-args']
    for p in params:
        args += ['-p', p]
    if without_cap_sys_nice:   # the same process, started by capsh without the capability
        args = ['capsh', '--drop=cap_sys_nice', '--', '-c', 'exec "$0" "$@"', *args]
    log = tmp_path / 'simulator.log'
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = Node('realtime_probe', context=ctx)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    got = []
    node.create_subscription(
        DiagnosticArray, '/diagnostics',
        lambda m: got.extend({kv.key: kv.value for kv in s.values} for s in m.status
                             if s.name.endswith('simulation')), 10)
    with open(log, 'w') as out:
        proc = subprocess.Popen(args, stdout=out, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + DEADLINE_S
        while not any(float(v['steps']) > 0 for v in got):
            assert proc.poll() is None, log.read_text()
            assert time.monotonic() < deadline, 'no simulation status'
            executor.spin_once(timeout_sec=0.05)
        n = len(got)
        while len(got) == n:     # a status from a window in which the thread was integrating
            assert time.monotonic() < deadline, 'no second simulation status'
            executor.spin_once(timeout_sec=0.05)
        policies = thread_policies(proc.pid)
        policy = policies['abb_plant']
        state = got[-1]['scheduling']
    finally:
        proc.send_signal(signal.SIGINT)
        code = proc.wait(timeout=30)
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=ctx)
    return state, policy, log.read_text(), code, policies


def test_paced_integration_runs_under_sched_fifo_or_reports_the_refusal(tmp_path):
    state, (policy, priority), log, code, policies = run_simulator(
        tmp_path, 'realtime_priority:=10')
    assert code == 0 and 'Traceback' not in log
    others = {name: p for name, p in policies.items() if name != 'abb_plant'}
    assert all(p == (os.SCHED_OTHER, 0) for p in others.values()), others
    if policy == os.SCHED_FIFO:
        assert (state, priority) == ('SCHED_FIFO 10', 10)
        assert 'integrating under SCHED_FIFO 10' in log
    else:
        assert policy == os.SCHED_OTHER
        assert state.startswith('normal (SCHED_FIFO 10 refused')
        assert 'realtime_priority 10 refused by the system' in log


def test_as_fast_as_possible_never_runs_under_sched_fifo(tmp_path):
    state, (policy, _), log, code, _ = run_simulator(
        tmp_path, 'realtime_priority:=10', 'real_time_factor:=0.0')
    assert code == 0 and 'Traceback' not in log
    assert policy == os.SCHED_OTHER and state == 'normal'


@pytest.mark.skipif(shutil.which('capsh') is None or os.geteuid() != 0
                    or resource.getrlimit(resource.RLIMIT_RTPRIO)[0] != 0,
                    reason='needs capsh, root and no rtprio limit to take CAP_SYS_NICE away')
def test_a_refused_priority_is_one_warning_and_the_plant_runs_on(tmp_path):
    state, (policy, _), log, code, _ = run_simulator(tmp_path, 'realtime_priority:=10',
                                                     without_cap_sys_nice=True)
    assert code == 0 and 'Traceback' not in log
    assert policy == os.SCHED_OTHER
    assert state.startswith('normal (SCHED_FIFO 10 refused')
    assert log.count('realtime_priority 10 refused by the system') == 1
