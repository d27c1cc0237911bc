"""`abb-sim run`: the headless command line, its JSON summary and its errors (exit code 2),
in-process through ``cli.main`` (the console script: test_cli_smoke.py)."""

import json

import pytest


def test_run_p3_prints_one_json_summary(abb_sim):
    code, out, err = abb_sim('run', '--scenario', 'p3', '--duration', '3', '--json')
    assert code == 0, err
    summary = json.loads(out)
    assert summary['scenario'] == 'p3' and summary['n'] == 2
    assert summary['wbar'] == pytest.approx(2.7)
    assert summary['final_rbar'] < 1e-6
    assert sorted(summary['ball_angles_deg']) == pytest.approx([-106.13, 106.13], abs=0.05)
    assert summary['wall_time_s'] > 0 and summary['real_time_factor'] > 0


def test_no_abb_and_dimensionless_settings(abb_sim):
    code, out, err = abb_sim('run', '--scenario', 'p3', '--no-abb', '--set', 'wbar=1.5',
                             '--set', 'zeta=0.1', '--duration', '1', '--json')
    assert code == 0, err
    summary = json.loads(out)
    assert summary['n'] == 0 and summary['ball_angles_deg'] == []
    assert summary['wbar'] == pytest.approx(1.5)
    assert summary['final_rbar'] > 1e-3


@pytest.mark.parametrize('args,fragment', [
    (['--scenario', 'p9'], "'scenario'"),
    (['--set', 'k=-3'], "'k' = -3.0 is invalid: valid range is [0.003972, 3.972e+09] N/m"),
    (['--set', 'wbarr=2'], "'wbarr'"),
    (['--set', 'n=2.5'], "'n'"),
    (['--set', 'mbar=abc'], "'mbar'"),
    (['--set', 'J_y=1e-5'], "'J_y'"),
    (['--duration', '-1'], "'duration'"),
])
def test_bad_input_exits_2_naming_the_parameter(abb_sim, args, fragment):
    code, out, err = abb_sim('run', *args, '--json', '--no-progress')
    assert code == 2
    assert fragment in err
    assert 'Traceback' not in err and out == ''


def test_malformed_scenario_file_is_a_clear_error(abb_sim, tmp_path):
    bad = tmp_path / 'bad.yaml'
    bad.write_text('name: x\nset: {wbar: [1, 2}\n')
    code, _, err = abb_sim('run', '--scenario', str(bad), '--json')
    assert code == 2 and 'malformed' in err
    wrong = tmp_path / 'wrong.yaml'
    wrong.write_text('name: x\nspindle: {model: turbo}\n')
    code, _, err = abb_sim('run', '--scenario', str(wrong), '--json')
    assert code == 2 and "'scenario.spindle.model'" in err


def test_out_writes_a_bag_and_refuses_to_overwrite_it(abb_sim, tmp_path):
    from abb_ros.io.bag.reader import read_bag
    out = tmp_path / 'p3bag'
    code, stdout, err = abb_sim('run', '--scenario', 'p3', '--duration', '0.2', '--out', str(out),
                                '--json')
    assert code == 0, err
    summary = json.loads(stdout)
    topics = {}
    for topic, msg, _ in read_bag(out):
        topics.setdefault(topic, []).append(msg)
    assert len(topics['/joint_states']) == 201             # t = 0 and 200 publish periods
    assert summary['messages'] == sum(len(v) for v in topics.values())
    last = topics['/joint_states'][-1]
    assert list(last.name) == ['spindle', 'ball_1', 'ball_2']
    code, _, err = abb_sim('run', '--scenario', 'p3', '--duration', '0.1', '--out', str(out))
    assert code == 2 and '--overwrite' in err


def test_a_run_that_blows_up_stops_with_a_clear_message_and_a_readable_bag(abb_sim, tmp_path):
    """k = 1e9 N/m is a valid washer, but its mode (~1.5e5 rad/s) is far beyond a 10 kHz RK4:
    the run stops at once, exit code 1, no traceback, and the bag written so far is closed."""
    from abb_ros.io.bag.reader import read_bag
    out = tmp_path / 'stiff'
    code, stdout, err = abb_sim('run', '--set', 'k=1e9', '--duration', '0.1', '--out', str(out),
                                '--no-progress')
    assert code == 1 and stdout == ''
    assert 'simulation stopped' in err and 'envelope' in err and 'Traceback' not in err
    topics = {topic for topic, _, _ in read_bag(out)}
    assert '/joint_states' in topics          # the initial sample was written, then closed
