"""The analysis node on a live ten-ball plant at P3 (Figs. 15, 16): balanced, judged on the
member of the balanced family where the balls are, with the family's neutral modes removed.

Before the transverse multipliers, this drive reported ERROR "unbalanced" while its balls
balanced (its eight multipliers at 1 came out a few ulp above 1)."""

import signal
import subprocess
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from test_analysis_node import OMEGA0, Probe, _start, _wrapped_deg

from abb_ros.io.files.drive_file import write_drive_yaml
from abb_ros.model.parameters.params import DriveParams

TEN_BALLS = DriveParams(c=0.66, n=10, m=0.03 * 0.026 * 2 / 10)
"""P3's drive (metal washers) with ten balls of the two balls' total mass."""


@pytest.mark.slow
def test_ten_balls_at_p3_are_reported_balanced_on_the_member_where_they_settled(tmp_path):
    params_file = tmp_path / 'p3_n10.yaml'
    write_drive_yaml(TEN_BALLS, params_file)
    logs = {name: open(tmp_path / f'{name}.log', 'w+') for name in ('simulator', 'analysis')}
    procs = [_start('simulator', params_file, 'real_time_factor:=0.0', 'publish_rate_hz:=200',
                    f'spindle.initial_speed:={2.7 * OMEGA0}', log=logs['simulator']),
             _start('analysis', params_file, log=logs['analysis'])]
    probe = Probe()
    try:
        def settled_status():
            recent = probe.joint_states[-200:]
            if len(recent) < 200 or not probe.statuses:
                return None
            spread = np.ptp(np.array([_wrapped_deg(js[3]) for js in recent]), axis=0).max()
            if spread > 0.05:
                return None
            s = probe.statuses[-1]
            if s[4].get('family_member') == 'nearest the balls' and s[0] > recent[-1][0] - 1:
                return s
            return None

        level, message, values = probe.wait_for(settled_status, 120.0,
                                                'a verdict on the settled balls')[2:]
        assert level == DiagnosticStatus.OK, message
        assert 'balanced and stable' in message
        assert values['neutral_modes_removed'] == '8'
        assert float(values['family_invariance']) < 1e-9
        assert values['source'].startswith('exact')
        member = np.array([float(x) for x in values['phi_star_deg'].split(',')])
        balls = _wrapped_deg(probe.joint_states[-1][3])
        assert np.abs(_wrapped_deg(np.radians(member - balls))).max() < 0.5
        assert 0.0 < float(values['margin']) < 0.1
    finally:
        probe.close()
        for proc in procs:
            proc.send_signal(signal.SIGINT)
        for proc, log in zip(procs, logs.values()):
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
            log.seek(0)
            print(log.read()[-3000:])
            log.close()
        time.sleep(0.1)
