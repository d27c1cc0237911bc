"""package.xml declares every run-time dependency the package imports (a colcon install with
rosdep gets what `abb-sim sweep`, the nodes and the CLI need)."""

import ast
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]

ROSDEP_KEYS = {
    'numpy': 'python3-numpy', 'scipy': 'python3-scipy', 'yaml': 'python3-yaml',
    'matplotlib': 'python3-matplotlib', 'tqdm': 'python3-tqdm', 'numba': 'python3-numba',
    'mcap': 'python3-mcap-pip', 'mcap_ros2': 'python3-mcap-ros2-support-pip',
    'tornado': 'python3-tornado', 're2': 'python3-google-re2-pip',
    'dask': 'python3-dask-pip', 'distributed': 'python3-distributed-pip',
    'pyarrow': 'python3-pyarrow-pip', 'zstandard': 'python3-zstandard', 'lz4': 'python3-lz4',
    'launch': 'launch', 'launch_ros': 'launch_ros',
    'ament_index_python': 'ament_index_python', 'rclpy': 'rclpy', 'pytest': 'python3-pytest',
}
"""Top-level module -> its package.xml key; ROS message packages (``*_msgs``,
``*_interfaces``, ``std_srvs``) are keyed by their own name."""


def imported_top_levels():
    """{top-level module: first file importing it} over abb_ros/ (lazy imports included)."""
    found = {}
    for path in sorted((REPO / 'abb_ros').rglob('*.py')):
        for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                found.setdefault(name.split('.')[0], path.relative_to(REPO))
    return found


def test_every_third_party_import_is_an_exec_depend():
    root = ET.parse(REPO / 'package.xml').getroot()
    # <depend> is build, export and exec dependency at once (REP 149)
    run = {e.text for e in root.iter('exec_depend')} | {e.text for e in root.iter('depend')}
    test = {e.text for e in root.iter('test_depend')}
    missing = []
    for module, where in imported_top_levels().items():
        # abb_ros/testing (the pytest plugin, the lockstep harness) may use test dependencies
        declared = run | test if where.parts[:2] == ('abb_ros', 'testing') else run
        if module in sys.stdlib_module_names or module == 'abb_ros' or module == '__future__':
            continue
        ros_msgs = module.endswith(('_msgs', '_interfaces')) or module == 'std_srvs'
        key = module if ros_msgs else ROSDEP_KEYS.get(module)
        if key is None or key not in declared:
            missing.append(f'{module} ({where}): package.xml key {key!r}')
    assert not missing, 'undeclared run-time imports: ' + '; '.join(missing)
