"""The topic list (io/topics.py): one entry per topic, the derived lists in its order."""

from abb_ros.io import topics


def test_every_topic_has_one_entry_and_the_derived_lists_keep_its_order():
    """Check that every topic has one entry and the derived lists keep its order."""
    names = [t.name for t in topics.TOPICS]
    assert len(set(names)) == len(names)
    assert [t.name for t in topics.published_by('simulator')] == [
        'joint_states', 'deck/pose', 'deck/twist', 'deck/imu', 'spindle/speed', '/clock',
        'visualization/markers', '/diagnostics']
    assert [t.name for t in topics.sampled_topics()] == [
        'joint_states', 'deck/pose', 'deck/twist', 'deck/imu', 'spindle/speed', '/clock']
    assert '/clock' not in [t.name for t in topics.recorded_topics()]
    assert topics.by_name('deck/pose').frame == topics.FRAME_BASE
    assert topics.message_class('std_msgs/msg/Float64').__name__ == 'Float64'
