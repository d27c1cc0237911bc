"""The topic list (io/wire/topics.py): one entry per topic, the derived lists in its order."""

from abb_ros.io.wire import topics


def test_every_topic_has_one_entry_and_the_derived_lists_keep_its_order():
    """No topic is listed twice, and the simulator's, the headless bag's and the recorder's lists
    keep the order of TOPICS (the recorder without /clock)."""
    names = [t.name for t in topics.TOPICS]
    assert len(set(names)) == len(names)
    assert [t.name for t in topics.published_by('simulator')] == [
        'joint_states', 'deck/pose', 'deck/twist', 'deck/imu', 'spindle/speed', '/clock',
        'visualization/markers', '/diagnostics', 'joint_states_throttle']
    assert [t.name for t in topics.sampled_topics()] == [
        'joint_states', 'deck/pose', 'deck/twist', 'deck/imu', 'spindle/speed', '/clock']
    assert not {'/clock', 'joint_states_throttle'} & {t.name for t in topics.recorded_topics()}
    assert topics.by_name('deck/pose').frame == topics.FRAME_BASE
    assert topics.message_class('std_msgs/msg/Float64').__name__ == 'Float64'


def topic_name_literals(source: str) -> list[tuple[int, str]]:
    """Return (line, text) of every string constant in ``source`` that is a topic's name."""
    import ast
    names = {t.name for t in topics.TOPICS}
    names |= {'/' + n for n in names}
    return [(node.lineno, node.value) for node in ast.walk(ast.parse(source))
            if isinstance(node, ast.Constant) and node.value in names]


def test_topic_names_are_written_only_in_the_topic_list():
    from pathlib import Path
    package = Path(topics.__file__).resolve().parents[1]
    found = {}
    for path in sorted(package.rglob('*.py')):
        if path.name == 'topics.py' and path.parent.name == 'wire':
            continue
        hits = topic_name_literals(path.read_text())
        if hits:
            found[str(path.relative_to(package))] = hits
    assert not found, f'topic names written outside io/wire/topics.py (use its constants): {found}'


def test_the_topic_name_check_sees_a_literal_but_not_a_sentence():
    source = ("x = 'deck/pose'\n"
              "y = topics.DECK_POSE\n"
              "z = 'ROS topic names (\\'stability/margin\\', ...)'\n")
    assert topic_name_literals(source) == [(1, 'deck/pose')]
