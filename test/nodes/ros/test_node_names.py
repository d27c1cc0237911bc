"""Node names stay unique under the remaps ``ros2 launch`` passes.

launch_ros starts a node with ``name=X, namespace=/ns`` as ``--ros-args -r __node:=X -r
__ns:=/ns``: remaps that rcl applies to every node of the process. Each executable runs here
as a process with those arguments, and a node of the test lists the graph over DDS
(``get_node_names_and_namespaces``, what ``ros2 node list -a`` shows): every name occurs
once, the node has the launch name, and its hidden helpers have names derived from it.
"""

import collections
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import rclpy
from rclpy.node import Node

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[3]
DEADLINE_S = 60.0   # includes the processes' start-up (imports, kernel cache) on a loaded machine


def remapped(module, name, namespace, *params, tmp_path):
    """Start ``python -m module`` with launch's remaps and ``-p`` ``params``."""
    args = [sys.executable, '-m', module, '--ros-args', '-r', f'__node:={name}',
            '-r', f'__ns:={namespace}']
    for param in params:
        args += ['-p', param]
    log = open(tmp_path / f'{name}.log', 'w+')
    return subprocess.Popen(args, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT), log


@pytest.fixture
def graph():
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = Node('name_probe', context=ctx)
    yield node
    node.destroy_node()
    rclpy.shutdown(context=ctx)


def test_launch_remaps_give_every_node_and_helper_a_name_of_its_own(graph, tmp_path):
    """The analysis node, the recorder and the simulator recording in process and serving
    other nodes' topics on its live view (two helpers) all get ``-r __node:=X``."""
    procs = [
        remapped('abb_ros.nodes.analysis', 'ana', '/bench', tmp_path=tmp_path),
        remapped('abb_ros.nodes.recorder', 'rec', '/bench', f'output:={tmp_path / "bag"}',
                 tmp_path=tmp_path),
        remapped('abb_ros.nodes.simulator', 'sim', '/bench', f'record.path:={tmp_path / "b2"}',
                 'record.topics:=[stability/margin]', 'live_view.enabled:=true',
                 'live_view.port:=0', tmp_path=tmp_path),
    ]
    wanted = {('ana', '/bench'), ('_ana_taps', '/bench'), ('rec', '/bench'),
              ('_rec_taps', '/bench'), ('sim', '/bench'), ('_sim_record_taps', '/bench'),
              ('_sim_live_view_taps', '/bench')}
    try:
        deadline = time.monotonic() + DEADLINE_S
        names = []
        while time.monotonic() < deadline:
            names = [n for n in graph.get_node_names_and_namespaces() if n[1] == '/bench']
            if wanted <= set(names):
                break
            time.sleep(0.2)
        assert wanted <= set(names), names
        time.sleep(1.0)   # anything else would have shown by now
        names = [n for n in graph.get_node_names_and_namespaces() if n[1] == '/bench']
        twice = [n for n, count in collections.Counter(names).items() if count > 1]
        assert not twice, names
        assert set(names) == wanted
    finally:
        for proc, log in procs:
            proc.send_signal(signal.SIGINT)
        for proc, log in procs:
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
            log.close()
    for proc, log in procs:
        assert proc.returncode == 0, Path(log.name).read_text()


def test_a_helper_keeps_the_command_lines_topic_remaps_and_takes_its_owners_namespace():
    """Only the helper's name and namespace are its own: ``-r joint_states:=/js`` of the
    command line moves its subscription as it moves its owner's."""
    from sensor_msgs.msg import JointState

    from abb_ros.nodes.ros.taps import Taps

    ctx = rclpy.Context()
    rclpy.init(context=ctx, args=['--ros-args', '-r', '__node:=owner', '-r', '__ns:=/a',
                                  '-r', 'joint_states:=/js'])
    try:
        owner = Node('abb_analysis', context=ctx)
        taps = Taps(owner)
        sub = taps.subscribe(JointState, 'joint_states', 1)
        assert (owner.get_name(), owner.get_namespace()) == ('owner', '/a')
        assert (taps.node.get_name(), taps.node.get_namespace()) == ('_owner_taps', '/a')
        assert sub.topic_name == '/js'
        taps.destroy()
        owner.destroy_node()
    finally:
        rclpy.shutdown(context=ctx)
