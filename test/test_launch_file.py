"""launch/bench.launch.py, checked without the launch library (no wheel exists): it is Python
that imports only launch and launch_ros, declares the documented arguments, and starts the
package's own console scripts under the nodes' own names. (That colcon installs it to
share/abb_ros/launch: test_installed_layout.py.)"""

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAUNCH = ROOT / 'launch' / 'bench.launch.py'
ARGUMENTS = {'namespace', 'params_file', 'real_time_factor', 'realtime_priority', 'analysis',
             'controller', 'record', 'record_dir'}


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


def test_launch_file_declares_every_argument_of_the_issue_and_documents_it():
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


def test_the_recording_covers_every_topic_the_bench_nodes_publish():
    from abb_ros.io.ros_messages import TOPIC_TYPES
    from abb_ros.io.topics import recorded_topics
    DEFAULT_TOPICS = [t.name for t in recorded_topics()]
    (topics,) = [n.value for n in tree().body if isinstance(n, ast.Assign)
                 and n.targets[0].id == 'BENCH_TOPICS']
    recorded = set(ast.literal_eval(topics))
    assert recorded >= set(TOPIC_TYPES) | set(DEFAULT_TOPICS)
    assert recorded >= {'spindle/speed_cmd', 'stability/margin'}


def test_every_node_in_the_launch_file_is_a_console_script_of_this_package():
    setup = (ROOT / 'setup.py').read_text()
    scripts = dict(re.findall(r"'(\w+) = (abb_ros\.nodes\.\w+):main'", setup))
    calls = node_calls()
    assert {c['executable'] for c in calls} == {'simulator', 'analysis', 'spin_controller',
                                                'recorder'}
    for call in calls:
        assert call['package'] == 'abb_ros'
        module = scripts[call['executable']]
        source = (ROOT / (module.replace('.', '/') + '.py')).read_text()
        # The launch name is the node's own, so parameter files and docs stay valid.
        assert f"'{call['name']}'" in source, (call['name'], module)


def test_the_simulators_own_recording_takes_the_other_nodes_topics_of_the_bench():
    from abb_ros.io.topics import TOPICS
    (topics,) = [n.value for n in tree().body if isinstance(n, ast.Assign)
                 and n.targets[0].id == 'OTHER_NODES_TOPICS']
    others = {t.name for t in TOPICS if set(t.publishers) != {'simulator'}}
    assert set(ast.literal_eval(topics)) == others
