"""`abb-sim plot`: rbar, ball angles and deck coordinates read back from a bag (Figs. 9-16).

The bags are synthetic (a decaying whirl of C, balls settling at +-106 deg as in Fig. 11), so the
expected numbers are known in closed form.
"""

import json

import numpy as np
import pytest
from cdr_reference import cdr_bytes
from geometry_msgs.msg import PoseStamped
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import JointState

from abb_ros.cli import main
from abb_ros.io.bag.time_response import euler_from_quaternion, load_time_response
from abb_ros.io.bag.writer import BagWriter

R_RACE = 0.015
PHI_END = np.radians(106.0)


def whirl(t, amplitude):
    """X, Y of C whirling at 100 rad/s with a decaying radius; Z, angles small."""
    r = amplitude * np.exp(-t)
    return r * np.cos(100 * t), r * np.sin(100 * t), 1e-6 * np.sin(30 * t)


def write_run(path, amplitude=3e-5, store_params=True, stamp=True):
    """A 2 s run at 500 Hz; header stamps are the simulated time when ``stamp``."""
    times = np.arange(0, 2.0, 0.002)
    with BagWriter(path) as bag:
        bag.add_topic('deck/pose', 'geometry_msgs/msg/PoseStamped')
        bag.add_topic('joint_states', 'sensor_msgs/msg/JointState')
        if store_params:
            bag.set_drive_params({'R': R_RACE, 'n': 2})
        for k, t in enumerate(times):
            ns = 5_000_000_000 + int(round(t * 1e9))
            x, y, z = whirl(t, amplitude)
            pose = PoseStamped()
            pose.header.frame_id = 'base'
            if stamp:
                pose.header.stamp.sec, pose.header.stamp.nanosec = divmod(ns, 1_000_000_000)
            pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = x, y, z
            qx, qy, qz, qw = Rotation.from_euler(
                'ZXY', [1e-3 * t, 2e-3 * t, -1e-3 * t]).as_quat()
            o = pose.pose.orientation
            o.x, o.y, o.z, o.w = qx, qy, qz, qw
            settle = 1 - np.exp(-3 * t)
            joints = JointState(name=['spindle', 'ball_1', 'ball_2'],
                                position=[100.0 * t, PHI_END * settle, -PHI_END * settle])
            joints.header = pose.header
            bag.write('deck/pose', cdr_bytes(pose), ns + 1000)
            bag.write('joint_states', cdr_bytes(joints), ns + 2000)
    return times


def test_euler_angles_follow_the_paper_sequence_gamma_z_alpha_x_beta_y():
    rng = np.random.default_rng(7)
    angles = rng.uniform(-0.6, 0.6, size=(50, 3))  # (gamma, alpha, beta), away from gimbal lock
    q = Rotation.from_euler('ZXY', angles).as_quat()  # intrinsic: Rz(gamma) Rx(alpha) Ry(beta)
    alpha, beta, gamma = euler_from_quaternion(*q.T)
    # Exact up to floating-point rounding of the quaternion products.
    np.testing.assert_allclose(np.c_[gamma, alpha, beta], angles, atol=1e-12)


def test_rbar_and_ball_angles_are_read_back_from_the_bag(tmp_path):
    times = write_run(tmp_path / 'run')
    resp = load_time_response(tmp_path / 'run')
    assert (resp.R, resp.R_source) == (R_RACE, 'bag')
    # Times come from the header stamps (simulated time), relative to the first one.
    np.testing.assert_allclose(resp.t_pose, times, atol=1e-9)
    x, y, z = whirl(times, 3e-5)
    np.testing.assert_allclose(resp.rbar, np.sqrt(x**2 + y**2 + z**2) / R_RACE, rtol=1e-12)
    np.testing.assert_allclose(resp.deck[5], 1e-3 * times, atol=1e-12)  # gamma
    np.testing.assert_allclose(resp.phi[:, -1], PHI_END * (1 - np.exp(-3 * times[-1])) *
                               np.array([1, -1]), rtol=1e-12)


@pytest.mark.slow   # four figures: about 10 s of matplotlib on a shared 2-core machine
def test_plot_command_writes_the_figures_and_summarises_the_run(tmp_path, capsys):
    write_run(tmp_path / 'abb')
    write_run(tmp_path / 'no_abb', amplitude=2e-4)
    code = main(['plot', str(tmp_path / 'abb'), '--compare', str(tmp_path / 'no_abb'),
                 '--out', str(tmp_path / 'fig'), '--json'])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    assert sorted(p.rsplit('/', 1)[1] for p in summary['figures']) == [
        'abb_comparison.png', 'deck.png', 'deck_without_abb.png', 'rbar_balls.png']
    for path in summary['figures']:
        with open(path, 'rb') as f:
            assert f.read(8) == b'\x89PNG\r\n\x1a\n'
    t_end = 1.998
    x, y, z = whirl(t_end, 3e-5)
    assert summary['final_rbar'] == pytest.approx(np.sqrt(x**2 + y**2 + z**2) / R_RACE,
                                                  rel=1e-12)
    # +-106 deg approached as 1 - exp(-3 t): at t = 1.998 s within 0.3 deg of it.
    assert summary['final_ball_angles_deg'] == pytest.approx([106.0, -106.0], abs=0.3)
    assert summary['max_rbar_last_tenth_without_abb'] > 6 * summary['max_rbar_last_tenth']


@pytest.mark.slow   # two figures
def test_without_stored_parameters_R_comes_from_the_option_then_table_1(tmp_path, capsys):
    write_run(tmp_path / 'bag', store_params=False, stamp=False)
    resp = load_time_response(tmp_path / 'bag')
    assert (resp.R, resp.R_source) == (0.015, 'Table 1')
    assert resp.t_pose[0] == 0.0  # receive times used when the header stamp is zero
    assert main(['plot', str(tmp_path / 'bag'), '--R', '0.03', '--out',
                 str(tmp_path / 'fig'), '--json']) == 0
    summary = json.loads(capsys.readouterr().out)
    assert (summary['R_m'], summary['R_source']) == (0.03, '--R')


def test_a_bag_without_deck_pose_or_a_bad_path_is_a_usage_error(tmp_path, capsys):
    with BagWriter(tmp_path / 'empty') as bag:
        bag.add_topic('joint_states', 'sensor_msgs/msg/JointState')
    assert main(['plot', str(tmp_path / 'empty'), '--out', str(tmp_path / 'f')]) == 2
    assert 'no deck/pose messages' in capsys.readouterr().err
    assert main(['plot', str(tmp_path / 'nope'), '--out', str(tmp_path / 'f')]) == 2
    assert 'does not exist' in capsys.readouterr().err
    assert main(['plot', str(tmp_path / 'empty'), '--R', '-1', '--out', 'x']) == 2


def test_a_map_title_too_wide_for_the_figure_goes_on_lines_that_fit():
    """fig7b_n10's title ran off the right edge: sentences go on lines of their own, broken
    after commas outside $math$, each line within the figure; a short title stays as it is."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from abb_ros.plots.labels import fit_title

    fig, ax = plt.subplots(figsize=(6.0, 5.4))
    try:
        long = (r'Fig. 7(b) with n = 10. In-plane stability: $\zeta$ = 0.025 (metal washers), '
                r'$\bar{\epsilon}$ = 0.0167, n = 10, $\bar{D}$ = 0.474, $\bar{m}$ = 0.006')
        fit_title(fig, ax, long)
        lines = ax.get_title().split('\n')
        assert lines[0] == 'Fig. 7(b) with n = 10.' and len(lines) >= 3
        assert ' '.join(lines) == long
        renderer = fig.canvas.get_renderer()
        for line in lines:
            ax.set_title(line, fontsize=10)
            assert ax.title.get_window_extent(renderer).width <= fig.get_figwidth() * fig.dpi
        fit_title(fig, ax, 'Fig. 7(b). Short')
        assert ax.get_title() == 'Fig. 7(b). Short'
    finally:
        plt.close(fig)


def test_a_basin_title_too_wide_keeps_its_lines_and_breaks_after_a_semicolon():
    """The basin picture's second line (P(balance); Floquet verdict) ran off the right edge:
    its given line break stays, and the too-wide line is broken after '; ' into lines that
    each fit the figure."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from abb_ros.plots.labels import fit_title

    fig, ax = plt.subplots(figsize=(6.4, 6.2))
    try:
        head = 'p3, n = 2, 1024 runs of 3 s'
        verdict = ('P(balance) = 0.969 [0.956, 0.978] 95 %; Floquet at wbar 2.7: balanced '
                   '(|lambda|max in 0.9443, out 0.9711)')
        fit_title(fig, ax, f'{head}\n{verdict}', fontsize=8)
        lines = ax.get_title().split('\n')
        assert lines[0] == head and len(lines) >= 3
        assert lines[1].endswith('95 %;')
        assert ' '.join(lines[1:]) == verdict
        renderer = fig.canvas.get_renderer()
        for line in lines:
            ax.set_title(line, fontsize=8)
            assert ax.title.get_window_extent(renderer).width <= fig.get_figwidth() * fig.dpi
    finally:
        plt.close(fig)
