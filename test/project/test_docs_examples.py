"""What the docs quote from the code is what the code says.

The scenario list (docs/cli.md, ``abb-sim run --help``), the recorder's default topics
(docs/ros_api.md) and the refusal texts shown in docs/architecture.md and docs/ros_api.md are
compared with the code that produces them: the shipped scenario files, ``recorded_topics()``,
``abb-sim`` and the nodes' parameter refusals over rclpy.
"""

import re
from pathlib import Path

import pytest

from abb_ros import cli
from abb_ros.io.files.scenario import list_scenarios
from abb_ros.io.wire.topics import recorded_topics

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / 'docs'


def section(path: Path, heading: str) -> str:
    """The text of the section ``heading`` (a Markdown heading line) up to the next heading."""
    text = path.read_text()
    start = text.index(f'\n{heading}\n')
    end = re.search(r'\n#{1,3} ', text[start + len(heading) + 2:])
    return text[start:start + len(heading) + 2 + end.start()] if end else text[start:]


def quoted(path: Path, start: str) -> list[str]:
    """Every backticked span of ``path`` (line breaks as spaces) that begins with ``start``."""
    text = ' '.join(path.read_text().split())
    return re.findall(rf'`({re.escape(start)}[^`]*)`', text)


def test_every_shipped_scenario_is_described_in_cli_md_and_named_by_run_help(capsys):
    names = list_scenarios()
    assert 'runup_torque_weak' in names and len(names) >= 8
    described = section(DOCS / 'cli.md', '## Scenarios')
    named = set(re.findall(r'`([a-z0-9_]+)`', described))
    named |= {f'p{k}' for k in range(1, 5)} if '`p1`..`p4`' in described else set()
    assert set(names) <= named, set(names) - named
    assert cli.main(['run', '--help']) == 0
    help_text = ' '.join(capsys.readouterr().out.split())
    assert all(re.search(rf'\b{n}\b', help_text) for n in names), help_text


def test_ros_api_gives_the_recorders_default_topics_in_the_order_of_the_code():
    text = ' '.join((DOCS / 'ros_api.md').read_text().split())
    listed = re.search(r'a wanted topic appears \(default: (.*?), which is '
                       r'`io/wire/topics.recorded_topics\(\)`', text)
    assert listed, 'the recorder default topic list is not where it was'
    assert re.findall(r'`([^`]+)`', listed.group(1)) == [t.name for t in recorded_topics()]


def test_the_cli_refusal_quoted_in_architecture_md_is_what_abb_sim_prints(capsys):
    assert cli.main(['stability', '--set', 'k=0']) == 2
    printed = capsys.readouterr().err.strip()
    [example] = quoted(DOCS / 'architecture.md', "parameter 'k' = 0.0 is invalid")
    assert printed == f'abb-sim stability: error: {example}'


@pytest.mark.ros
def test_the_node_refusals_quoted_in_ros_api_md_are_the_nodes_reasons():
    import rclpy
    from rclpy.parameter import Parameter

    from abb_ros.nodes.simulator.node import SimulatorNode

    [out_of_range] = quoted(DOCS / 'ros_api.md', 'Parameter drive.k out of range')
    [as_a_whole] = quoted(DOCS / 'ros_api.md', "parameter 'publish_rate_hz' = 3000")
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    try:
        node = SimulatorNode(context=ctx, parameter_overrides=[
            Parameter('start_paused', value=True)])
        try:
            results = [node.set_parameters([p])[0] for p in (
                Parameter('drive.k', value=0.0), Parameter('publish_rate_hz', value=3000))]
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown(context=ctx)
    assert not any(r.successful for r in results)
    assert [r.reason for r in results] == [out_of_range, as_a_whole]
