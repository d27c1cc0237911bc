"""The `abb-sim` console script, one subprocess per command: the installed entry point starts,
runs the command and prints one JSON object (everything else is tested in-process through
``cli.main``: test_cli_run.py, test_cli_analysis.py, test_plot.py, test_cli_bad_input.py).
Each starts Python, numba, scipy and matplotlib afresh (5-20 s on a shared 2-core machine): slow,
except freqs (scipy only) and the argument error, which must come at once (the parser imports no
numerical code)."""

import json
import os
import subprocess
import sys
import time

import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from abb_ros.io.bag.reader import bag_files, read_bag
from abb_ros.io.bag.writer import topic_name
from abb_ros.io.wire.topics import sampled_topics

ABB_SIM = os.path.join(os.path.dirname(sys.executable), 'abb-sim')


def abb_sim(*args):
    proc = subprocess.run([ABB_SIM, *args, '--json'], capture_output=True, text=True,
                          timeout=300, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout), proc.stderr


DURATION_S = 0.2


@pytest.fixture(scope='module')
def p3_run(tmp_path_factory):
    """(bag directory, summary) of ``abb-sim run --scenario p3 --duration 0.2 --out ...``."""
    out = tmp_path_factory.mktemp('smoke') / 'p3'
    summary, _ = abb_sim('run', '--scenario', 'p3', '--duration', str(DURATION_S),
                         '--out', str(out), '--no-progress')
    assert summary['scenario'] == 'p3' and summary['messages'] > 0
    assert summary['bag'] == str(out)
    return out, summary


@pytest.fixture(scope='module')
def p3_bag(p3_run):
    return p3_run[0]


@pytest.mark.slow
def test_abb_sim_run_writes_a_rosbag2_mcap_bag_of_every_sample(p3_run):
    """metadata.yaml is rosbag2 (v9, MCAP) metadata of the sampled topics that counts the
    messages the summary reports; the MCAP file, read by the mcap library, holds that many,
    each decodable, in time order over the run's 0.2 s."""
    bag, summary = p3_run
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['version'] == 9 and info['storage_identifier'] == 'mcap'
    assert info['message_count'] == summary['messages']
    assert info['duration']['nanoseconds'] == round(DURATION_S * 1e9)
    expected = [(topic_name(t.name), t.type) for t in sampled_topics()]
    listed = [(e['topic_metadata']['name'], e['topic_metadata']['type'])
              for e in info['topics_with_message_count']]
    assert listed == expected
    assert sum(e['message_count'] for e in info['topics_with_message_count']) \
        == summary['messages']
    (mcap_file,) = bag_files(bag)        # abb_ros's reader resolves relative_file_paths
    assert mcap_file.parent == bag

    with open(mcap_file, 'rb') as f:
        reader = make_reader(f, validate_crcs=True, decoder_factories=[DecoderFactory()])
        decoded = list(reader.iter_decoded_messages())
    assert len(decoded) == summary['messages']
    assert {c.topic for _, c, _, _ in decoded} == {name for name, _ in expected}
    assert {s.name for s, _, _, _ in decoded} == {kind for _, kind in expected}
    by_topic = {}
    for _, channel, message, _ in decoded:
        by_topic.setdefault(channel.topic, []).append(message.log_time)
    for topic, times in by_topic.items():
        assert all(b > a for a, b in zip(times, times[1:])), topic
        assert times[0] == 0 and times[-1] == round(DURATION_S * 1e9), topic
    # rclpy deserialises every message too (the types ROS nodes use).
    assert sum(1 for _ in read_bag(bag)) == summary['messages']


@pytest.mark.slow
def test_abb_sim_stability():
    summary, _ = abb_sim('stability', '--set', 'wbar=2.7', '--set', 'mbar=0.03')
    assert summary['verdict'] == 'balanced'


def test_abb_sim_freqs():
    summary, _ = abb_sim('freqs')
    assert summary['omega_Y_rad_s'] == pytest.approx(298.0, rel=0.04)


@pytest.mark.slow
def test_abb_sim_map_prints_progress_on_stderr_and_one_json_object_on_stdout(tmp_path):
    summary, err = abb_sim('map', '--x', 'wbar', '--y', 'zeta', '--res', '5x4',
                           '--set', 'mbar=0.03', '--out', str(tmp_path / 'f4.png'))
    assert summary['points'] == 20
    assert '20/20' in err   # tqdm's bar


@pytest.mark.slow
def test_abb_sim_plot(p3_bag, tmp_path):
    summary, _ = abb_sim('plot', str(p3_bag), '--out', str(tmp_path / 'figs'))
    assert len(summary['figures']) == 2 and all(os.path.exists(f) for f in summary['figures'])


@pytest.mark.slow
def test_abb_sim_basin_writes_its_table_summary_and_picture(tmp_path):
    summary, _ = abb_sim('basin', '--res', '2x2', '--duration', '0.05', '--serial',
                         '--no-progress', '--out', str(tmp_path / 'basin'))
    assert summary['runs'] == 4 and summary['integrator'] == 'rk4'
    assert {p.name for p in (tmp_path / 'basin').iterdir()} == {
        'basin.parquet', 'basin.json', 'basin.png', 'parts'}


def test_a_bad_input_is_one_line_and_exit_code_2():
    t0 = time.perf_counter()
    proc = subprocess.run([ABB_SIM, 'run', '--duration', 'ten'], capture_output=True, text=True,
                          timeout=300, stdin=subprocess.DEVNULL)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert '--duration' in proc.stderr
    assert time.perf_counter() - t0 < 5.0     # no numba, scipy or matplotlib imported
