"""SIGINT or SIGTERM at any moment, under CPU load, stops every node cleanly.

The simulator (n = 10, recording in process), the analysis node and the recorder run as
subprocesses next to a busy process; the signal goes to all three at a random moment in their
first seconds (imports, construction, kernel loading, discovery, steady running). Each must
exit 0 with no 'Traceback' and no 'FATAL' in its output, and both bags being written must be
finished (summary written) with metadata.yaml counting exactly the messages the file holds.

"Any moment" starts once the interpreter runs the package's first lines: the simulator runs
as ``python -m abb_ros.nodes.simulator`` (the module installs the stop handler before its
imports), the analysis node and the recorder as their console scripts, what ``ros2 run``
starts (abb_ros.nodes.ros.script installs it before importing the node module):
before that, during the interpreter's own start-up (site, .pth files; 0.05 s on an idle
machine, up to ~0.5 s on this loaded one), Python's default handlers apply and nothing in the
package can change that. The test waits until the process has begun importing rclpy (its
shared library is mapped), which comes after those lines.

Importing a node module, by contrast, installs no handler at all.

Ctrl-C of a launched bench reaches each node two or three times: the terminal signals the whole
process group, ``ros2 launch`` forwards its own SIGINT to each child, and an impatient user presses
again. A signal that lands while Python finalizes (when CPython has put the default handlers back)
must not kill the node with -2.
"""

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from abb_ros.io.bag.reader import is_finished, iter_raw

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[3]
ROUNDS = 3
LATEST_SIGNAL_S = 6.0
CTRL_C_ROUNDS = 20
NODE_MODULES = ('simulator', 'analysis', 'recorder', 'spin_controller')


@pytest.mark.parametrize('module', NODE_MODULES)
def test_importing_a_node_module_leaves_the_signal_handlers_as_they_were(module):
    code = (f'import signal, abb_ros.nodes.{module}\n'
            'assert signal.getsignal(signal.SIGINT) is signal.default_int_handler\n'
            'assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL\n')
    subprocess.run([sys.executable, '-c', code], cwd=ROOT, check=True, timeout=120)


def node(module, *params, console_script=False, process_group=None):
    if console_script:
        cmd = [str(Path(sys.executable).with_name(module)), '--ros-args']
    else:
        cmd = [sys.executable, '-m', f'abb_ros.nodes.{module}', '--ros-args']
    for p in params:
        cmd += ['-p', p]
    return subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            stdin=subprocess.DEVNULL, text=True, process_group=process_group)


@pytest.fixture
def cpu_hog():
    hog = subprocess.Popen([sys.executable, '-c', 'while True: pass'])
    yield hog
    hog.kill()
    hog.wait()


def wait_for_package_code(procs, timeout=60.0):
    """Until every process has mapped rclpy's library (it imports it after abb_ros.nodes)."""
    deadline = time.monotonic() + timeout
    for p in procs:
        while 'rclpy' not in Path(f'/proc/{p.pid}/maps').read_text(errors='replace'):
            assert p.poll() is None and time.monotonic() < deadline, 'a node did not start'
            time.sleep(0.005)


def bag_consistent(bag: Path) -> None:
    assert is_finished(bag), f'{bag} has no summary: not closed whole'
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    held = sum(1 for _ in iter_raw(bag))
    assert meta['message_count'] == held, (meta['message_count'], held)


@pytest.mark.usefixtures('cpu_hog')
@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_a_signal_at_a_random_moment_under_load_exits_0_without_traceback_or_fatal(
        tmp_path, sig):
    rng = random.Random()
    for k in range(ROUNDS):
        sim_bag, rec_bag = tmp_path / f'sim{k}', tmp_path / f'rec{k}'
        procs = {'simulator': node('simulator', 'drive.n:=10', f'record.path:={sim_bag}'),
                 'analysis': node('analysis', console_script=True),
                 'recorder': node('recorder', f'output:={rec_bag}', console_script=True)}
        wait_for_package_code(procs.values())
        delay = rng.uniform(0.0, LATEST_SIGNAL_S)
        time.sleep(delay)
        for p in procs.values():
            p.send_signal(sig)
        for name, p in procs.items():
            try:
                out, _ = p.communicate(timeout=60)
            except subprocess.TimeoutExpired:
                p.kill()
                out, _ = p.communicate()
                pytest.fail(f'{name} still running 60 s after {sig.name} at {delay:.2f} s:\n'
                            f'{out}')
            what = f'{name}, {sig.name} {delay:.2f} s after importing rclpy began:\n{out}'
            assert p.returncode == 0, what
            assert 'Traceback' not in out and 'FATAL' not in out, what
        for bag in (sim_bag, rec_bag):
            if bag.exists():   # not yet created if the signal came before construction
                bag_consistent(bag)


def group_ctrl_c(procs, rng):
    """A terminal's Ctrl-C under ``ros2 launch``: the group, then a forwarded SIGINT to each.

    A third SIGINT follows a little later (the user pressing again while the nodes shut down).
    """
    os.killpg(procs[0].pid, signal.SIGINT)
    for latest in (0.3, 1.5):
        time.sleep(rng.uniform(0.0, latest))
        for p in procs:
            if p.poll() is None:
                p.send_signal(signal.SIGINT)


@pytest.mark.usefixtures('cpu_hog')
def test_ctrl_c_to_the_process_group_with_forwarded_sigints_ends_every_node_with_0(tmp_path):
    rng = random.Random()
    for k in range(CTRL_C_ROUNDS):
        params = {'simulator': (), 'analysis': (),
                  'recorder': (f'output:={tmp_path / f"rec{k}"}',), 'spin_controller': ()}
        procs = {}
        for name, p in params.items():
            group = next(iter(procs.values())).pid if procs else 0
            procs[name] = node(name, *p, console_script=True, process_group=group)
        wait_for_package_code(procs.values())
        delay = rng.uniform(0.0, 3.0)
        time.sleep(delay)
        group_ctrl_c(list(procs.values()), rng)
        for name, p in procs.items():
            try:
                out, _ = p.communicate(timeout=60)
            except subprocess.TimeoutExpired:
                p.kill()
                out, _ = p.communicate()
                pytest.fail(f'round {k}: {name} still running 60 s after Ctrl-C:\n{out}')
            what = f'round {k}: {name}, Ctrl-C {delay:.2f} s after importing rclpy began:\n{out}'
            assert p.returncode == 0, what
            assert 'Traceback' not in out, what
