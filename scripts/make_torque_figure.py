"""docs/figures/torque/sommerfeld.png: full-current run-ups in torque mode (Table 1, rubber
washers) of a weak motor (current limit 0.05 A) and a strong one (0.2 A), K_t = 0.01 N m/A,
with the translational natural frequency marked (the Sommerfeld effect, docs/torque_mode.md).

Run from the repository root: ``nice -n 10 .venv/bin/python scripts/make_torque_figure.py``.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np

from abb_ros.model.dynamics.integrate import Simulation
from abb_ros.model.dynamics.spindle import TorqueMotor
from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.stability.linear import natural_frequencies

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402

OUT = Path(__file__).resolve().parent.parent / 'docs' / 'figures' / 'torque' / 'sommerfeld.png'
DT = 1e-4
DURATION = 6.0
MOTORS = {'weak motor, I_max = 0.05 A': 0.05, 'strong motor, I_max = 0.2 A': 0.2}


def speed_history(params, current_limit):
    """(t, omega) of a run-up from 1 rad/s at the full current, every 10 ms."""
    sim = Simulation(params, 1.0, DT, spindle=TorqueMotor(I_max=current_limit))
    sim.set_command(current_limit)
    y = sim.trajectory(int(round(DURATION / DT)), 100)
    return np.arange(1, len(y) + 1) * 100 * DT, y[:, 7 + params.n]


def main() -> int:
    params = DriveParams()
    w_res = natural_frequencies(params)['Y']
    fig, ax = plt.subplots(figsize=(7, 4))
    for label, limit in MOTORS.items():
        ax.plot(*speed_history(params, limit), label=label)
    ax.axhline(w_res, color='k', ls='--', lw=1,
               label=f'translational natural frequency {w_res:.0f} rad/s')
    ax.set_xlabel('t [s]')
    ax.set_ylabel('spindle speed omega [rad/s]')
    ax.set_title('Torque mode run-ups at full current (Table 1, rubber washers)')
    ax.legend(loc='center right')
    ax.grid(alpha=0.3)
    fig.tight_layout()
    OUT.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT, dpi=110)
    print(OUT)
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
