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

ABB_SIM = os.path.join(os.path.dirname(sys.executable), 'abb-sim')


def abb_sim(*args):
    proc = subprocess.run([ABB_SIM, *args, '--json'], capture_output=True, text=True,
                          timeout=300, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout), proc.stderr


@pytest.fixture(scope='module')
def p3_bag(tmp_path_factory):
    out = tmp_path_factory.mktemp('smoke') / 'p3'
    summary, _ = abb_sim('run', '--scenario', 'p3', '--duration', '0.2', '--out', str(out),
                         '--no-progress')
    assert summary['scenario'] == 'p3' and summary['messages'] > 0
    return out


@pytest.mark.slow
def test_abb_sim_run_writes_a_bag(p3_bag):
    assert (p3_bag / 'metadata.yaml').exists()


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


def test_a_bad_input_is_one_line_and_exit_code_2():
    t0 = time.perf_counter()
    proc = subprocess.run([ABB_SIM, 'run', '--duration', 'ten'], capture_output=True, text=True,
                          timeout=300, stdin=subprocess.DEVNULL)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert '--duration' in proc.stderr
    assert time.perf_counter() - t0 < 5.0     # no numba, scipy or matplotlib imported
