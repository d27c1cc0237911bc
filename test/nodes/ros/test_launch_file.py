"""launch/bench.launch.py: read as Python source, it imports only launch and launch_ros,
declares the documented arguments, starts the package's own console scripts under the
nodes' own names, and records the bench in the simulator's process; launched with the launch
library (where launch and launch_ros are importable: launch_ros has no PyPI wheel, so the test
is skipped without them), its three nodes run, are seen over DDS, and end with exit code 0
when the launch shuts down, the bag closed. (That colcon
installs it to share/abb_ros/launch: test_installed_layout.py.)"""

import ast
import asyncio
import importlib.util
import re
import shutil
import sys
import threading
import time
from pathlib import Path

import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from abb_ros.io.bag.reader import is_finished, iter_raw

ROOT = Path(__file__).resolve().parents[3]
LAUNCH = ROOT / 'launch' / 'bench.launch.py'
ARGUMENTS = {'namespace', 'params_file', 'real_time_factor', 'realtime_priority', 'analysis',
             'controller', 'record', 'record_dir', 'live_view', 'live_view_port'}


def tree() -> ast.Module:
    return ast.parse(LAUNCH.read_text(), filename=str(LAUNCH))


def node_calls() -> list[dict]:
    """Keyword arguments (constants only) of every Node(...) call."""
    calls = []
    for call in ast.walk(tree()):
        if isinstance(call, ast.Call) and getattr(call.func, 'id', None) == 'Node':
            calls.append({k.arg: k.value.value for k in call.keywords
                          if isinstance(k.value, ast.Constant)})
    return calls


def test_launch_file_imports_only_launch_and_launch_ros():
    roots = set()
    for node in ast.walk(tree()):
        if isinstance(node, ast.Import):
            roots |= {alias.name.split('.')[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            roots.add(node.module.split('.')[0])
    assert roots == {'launch', 'launch_ros'}
    functions = [n.name for n in tree().body if isinstance(n, ast.FunctionDef)]
    assert functions == ['generate_launch_description']


def test_launch_file_declares_its_arguments_and_documents_each():
    module = tree()
    (table,) = [n.value for n in module.body if isinstance(n, ast.Assign)
                and n.targets[0].id == 'ARGUMENTS']
    declared = {k.value for k in table.keys}
    assert declared == ARGUMENTS
    docs = (ROOT / 'docs' / 'ros_api.md').read_text()
    section = docs.split('## Bench launch file')[1].split('\n## ')[0]
    documented = set(re.findall(r'^\| `(\w+)` \|', section, flags=re.M))
    assert documented == ARGUMENTS
    # The default parameter file is the installed Table 1 file.
    text = LAUNCH.read_text()
    assert "FindPackageShare('abb_ros'), 'config'" in text and "'cdrom_table1.yaml'" in text
    assert (ROOT / 'config' / 'cdrom_table1.yaml').is_file()


def test_the_recording_is_the_simulators_own_and_covers_every_topic_of_the_bench():
    """record:=true sets the simulator's record.start and record_dir its record.path (no
    recorder node reads the 1 kHz topics from another process); its bag holds what the
    simulator publishes and OTHER_NODES_TOPICS, which together cover the recorder's defaults."""
    from abb_ros.io.wire.ros_messages import TOPIC_TYPES
    from abb_ros.io.wire.topics import recorded_topics
    text = LAUNCH.read_text()
    assert "'record.start': ParameterValue(LaunchConfiguration('record')" in text
    assert "'record.path': ParameterValue(LaunchConfiguration('record_dir')" in text
    (topics,) = [n.value for n in tree().body if isinstance(n, ast.Assign)
                 and n.targets[0].id == 'OTHER_NODES_TOPICS']
    recorded = set(TOPIC_TYPES) | set(ast.literal_eval(topics))
    assert recorded >= {t.name for t in recorded_topics()}


def test_every_node_in_the_launch_file_is_a_console_script_of_this_package():
    from abb_ros.nodes.ros.script import NODE_MODULES
    setup = (ROOT / 'setup.py').read_text()
    entry = dict(re.findall(r"'(\w+) = abb_ros\.nodes\.ros\.script:(\w+)'", setup))
    assert all(entry[name] == name for name in NODE_MODULES), entry
    scripts = {name: NODE_MODULES[name] for name in entry}
    calls = node_calls()
    assert {c['executable'] for c in calls} == {'simulator', 'analysis', 'spin_controller'}
    for call in calls:
        assert call['package'] == 'abb_ros'
        module = scripts[call['executable']]
        source = (ROOT / (module.replace('.', '/') + '.py')).read_text()
        # The launch name is the node's own, so parameter files and docs stay valid.
        assert f"'{call['name']}'" in source, (call['name'], module)


def test_the_bench_ends_when_the_simulator_ends():
    """A simulator that exits (a bad parameter: exit 2) shuts the launch down, instead of
    leaving the analysis and the controller running without a plant."""
    text = LAUNCH.read_text()
    simulator = text[text.index("executable='simulator'"):text.index("executable='analysis'")]
    assert "on_exit=Shutdown(" in simulator


def test_the_simulators_own_recording_takes_the_other_nodes_topics_of_the_bench():
    from abb_ros.io.wire.topics import TOPICS
    (topics,) = [n.value for n in tree().body if isinstance(n, ast.Assign)
                 and n.targets[0].id == 'OTHER_NODES_TOPICS']
    others = {t.name for t in TOPICS if set(t.publishers) != {'simulator'}}
    assert set(ast.literal_eval(topics)) == others


# ---- launched ---------------------------------------------------------------------------------

NAMESPACE = 'launch_test'
BENCH_NODES = {'abb_simulator', 'abb_analysis', 'abb_spin_controller'}
EXECUTABLES = ('simulator', 'analysis', 'spin_controller')
# Upper bounds for a loaded 2-core machine: the nodes start in seconds with the kernels cached.
FIRST_MESSAGES_TIMEOUT_S = 90.0
SHUTDOWN_TIMEOUT_S = 60.0      # launch's own escalation to SIGTERM comes after 30 s
MIN_MESSAGES = 3


def _launch_library():
    """The launch modules the test uses, or a skip naming what is missing."""
    for name in ('launch', 'launch_ros'):
        spec = importlib.util.find_spec(name)
        if spec is None or spec.origin is None:   # at most the repository's launch/ folder
            pytest.skip(f'the launch library is not importable (no module named {name!r}): '
                        'launch and launch_ros come with a ROS 2 Jazzy installation '
                        '(launch_ros has no PyPI wheel)')
    try:
        import launch_ros  # noqa: F401 - bench.launch.py imports it
        from launch import LaunchDescription, LaunchService
        from launch.actions import IncludeLaunchDescription, RegisterEventHandler
        from launch.event_handlers import OnProcessExit, OnProcessStart
        from launch.launch_description_sources import PythonLaunchDescriptionSource
    except ImportError as exc:
        pytest.skip(f'the launch library is not importable ({exc}): launch and launch_ros '
                    'come with a ROS 2 Jazzy installation (launch_ros has no PyPI wheel)')
    return (LaunchDescription, LaunchService, IncludeLaunchDescription, RegisterEventHandler,
            OnProcessExit, OnProcessStart, PythonLaunchDescriptionSource)


@pytest.fixture
def ament_prefix(tmp_path, monkeypatch) -> Path:
    """An install prefix on AMENT_PREFIX_PATH with what launch_ros resolves for abb_ros: the
    package's index entry, lib/abb_ros/<executable> (this environment's console scripts) and
    share/abb_ros/config/cdrom_table1.yaml (FindPackageShare)."""
    prefix = tmp_path / 'prefix'
    index = prefix / 'share' / 'ament_index' / 'resource_index' / 'packages'
    index.mkdir(parents=True)
    (index / 'abb_ros').write_text('')
    (prefix / 'share' / 'abb_ros' / 'config').mkdir(parents=True)
    shutil.copy(ROOT / 'config' / 'cdrom_table1.yaml', prefix / 'share' / 'abb_ros' / 'config')
    lib = prefix / 'lib' / 'abb_ros'
    lib.mkdir(parents=True)
    for exe in EXECUTABLES:
        script = Path(sys.executable).with_name(exe)     # the venv's, else the one on PATH
        found = script if script.exists() else shutil.which(exe)
        assert found, f'no console script {exe}: scripts/ensure-venv installs it in .venv/bin'
        (lib / exe).symlink_to(found)
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(prefix))
    monkeypatch.setenv('ROS_LOG_DIR', str(tmp_path / 'log'))
    return prefix


class _Observer:
    """A node in its own Context, spinning in a thread, that counts the bench's messages."""

    def __init__(self):
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx)
        self.node = Node('test_launch_observer', context=self.ctx)
        qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
        self.counts = {'joint_states': 0, 'stability/margin': 0, 'spindle/speed_cmd': 0}
        for topic, kind in zip(self.counts, (JointState, Float64, Float64)):
            self.node.create_subscription(kind, f'/{NAMESPACE}/{topic}',
                                          lambda _msg, t=topic: self._count(t), qos)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _count(self, topic):
        self.counts[topic] += 1

    def _spin(self):
        while not self._stop.is_set() and self.ctx.ok():
            self.executor.spin_once(timeout_sec=0.05)

    def bench_nodes(self) -> set[str]:
        return {name for name, ns in self.node.get_node_names_and_namespaces()
                if ns == f'/{NAMESPACE}'}

    def working(self) -> bool:
        return (self.bench_nodes() >= BENCH_NODES
                and min(self.counts.values()) >= MIN_MESSAGES)

    def close(self):
        self._stop.set()
        self._thread.join(timeout=10)
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.ctx)


@pytest.mark.slow
@pytest.mark.ros
@pytest.mark.usefixtures('ament_prefix')
def test_the_launched_bench_runs_its_three_nodes_and_shuts_them_down_cleanly(tmp_path):
    """ros2 launch abb_ros bench.launch.py namespace:=launch_test controller:=true record:=true,
    done with LaunchService: the simulator's joint_states, the analysis' stability/margin and
    the controller's speed commands arrive in the namespace over DDS, the three nodes are in
    the graph; after shutdown every process has ended with exit code 0 and the simulator's
    bag is closed and holds the joint states and the analysis' stability/margin."""
    (LaunchDescription, LaunchService, IncludeLaunchDescription, RegisterEventHandler,
     OnProcessExit, OnProcessStart, PythonLaunchDescriptionSource) = _launch_library()
    bag = tmp_path / 'bench_bag'
    started, exited = [], {}
    service = LaunchService(noninteractive=True)
    service.include_launch_description(LaunchDescription([
        RegisterEventHandler(OnProcessStart(
            on_start=lambda event, _ctx: started.append(event.process_name))),
        RegisterEventHandler(OnProcessExit(
            on_exit=lambda event, _ctx: exited.update({event.process_name: event.returncode}))),
        IncludeLaunchDescription(
            PythonLaunchDescriptionSource(str(LAUNCH)),
            launch_arguments={'namespace': NAMESPACE, 'controller': 'true', 'record': 'true',
                              'record_dir': str(bag)}.items()),
    ]))
    observer = _Observer()
    try:
        async def run_seen_and_shut_down():
            launched = asyncio.ensure_future(service.run_async())
            deadline = time.monotonic() + FIRST_MESSAGES_TIMEOUT_S
            while not (observer.working() or exited or launched.done()
                       or time.monotonic() > deadline):
                await asyncio.sleep(0.1)
            seen = (observer.bench_nodes(), dict(observer.counts), dict(exited))
            pending = service.shutdown()
            if pending is not None:
                await pending
            code = await asyncio.wait_for(launched, SHUTDOWN_TIMEOUT_S)
            return seen, code

        loop = asyncio.new_event_loop()
        try:
            (nodes, counts, ended_early), code = loop.run_until_complete(
                run_seen_and_shut_down())
        finally:
            loop.close()
    finally:
        observer.close()
    assert not ended_early, f'processes ended before the shutdown: {ended_early}'
    assert nodes >= BENCH_NODES, f'nodes in /{NAMESPACE}: {sorted(nodes)}'
    assert min(counts.values()) >= MIN_MESSAGES, \
        f'timed out after {FIRST_MESSAGES_TIMEOUT_S} s waiting for messages: {counts}'
    assert code == 0
    assert sorted(name.rsplit('-', 1)[0] for name in started) == sorted(EXECUTABLES)
    assert sorted(exited) == sorted(started)
    assert set(exited.values()) == {0}, exited
    assert is_finished(bag)
    for topic in ('joint_states', 'stability/margin'):
        assert sum(1 for _ in iter_raw(bag, [f'/{NAMESPACE}/{topic}'])) >= MIN_MESSAGES, topic
