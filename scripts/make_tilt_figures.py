"""docs/figures/two_plane/: the residual tilt one race leaves (docs/equations.md F4-F6).

- tilt_vs_offset.png: P3 (metal washers, mbar 0.03, wbar 2.7), the tilt against the lever
  z_G - z_B of the rotor's mass centre above the race, and against the lean tau of its axis:
  the coupled linearisation's periodic response (lines) and the nonlinear runs of
  ``abb-sim run --scenario p3 --json`` (points, their ``tilt_rad``).
- tilt_vs_speed.png: the same drive with G 1 mm above the race, the predicted tilt against the
  spindle speed wbar (unbalanced bands shaded: there the balls do not hold the balanced state
  and no tilt is predicted), with runs at three speeds.

Run from the repository root: ``nice -n 10 .venv/bin/python scripts/make_tilt_figures.py``
(about 2 minutes).
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from abb_ros.model.parameters.params import DriveParams, apply_settings
from abb_ros.model.stability import coupled, speed_bands
from abb_ros.plots.figure import pyplot, save

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / 'docs' / 'figures' / 'two_plane'
P3 = {'mbar': 0.03, 'c': 0.66}
LEVERS_MM = (0.25, 0.5, 1.0, 2.0, 5.0, 10.0)
LEANS_MRAD = (0.25, 0.5, 1.0, 2.0)
SPEEDS = (2.0, 2.7, 3.2)


def simulated_tilt(work: Path, *sets) -> float:
    """Return ``tilt_rad`` of a 6 s P3 run of abb-sim with ``sets`` (name=value)."""
    args = [sys.executable, '-m', 'abb_ros.cli', 'run', '--scenario', 'p3', '--duration', '6',
            '--json', '--no-progress', '--out', str(work / f'run{len(list(work.iterdir()))}')]
    for s in sets:
        args += ['--set', s]
    done = subprocess.run(args, capture_output=True, text=True, check=True, cwd=ROOT)
    return json.loads(done.stdout)['tilt_rad']


def predicted(settings: dict) -> float:
    params, omega = apply_settings(DriveParams(), {**P3, 'wbar': 2.7, **settings})
    return coupled.residual_tilt(params, omega)


def offset_panel(ax, work: Path, name: str, grid, runs, xlabel: str, title: str) -> None:
    """Draw the predicted tilt over ``grid`` and the runs at ``runs`` of offset ``name``
    (both in thousandths of its SI unit) on ``ax``."""
    ax.loglog(grid, [predicted({name: v * 1e-3}) * 1e3 for v in grid],
              label='coupled linearisation (periodic response)')
    ax.loglog(runs, [simulated_tilt(work, f'{name}={v * 1e-3}') * 1e3 for v in runs], 'o',
              label='nonlinear run, 6 s (abb-sim run)')
    ax.set_xlabel(xlabel)
    ax.set_title(title)
    ax.set_ylabel('residual tilt [mrad]')
    ax.grid(alpha=0.3, which='both')
    ax.legend()


def offset_figure(work: Path) -> str:
    fig, (ax_z, ax_t) = pyplot().subplots(1, 2, figsize=(10, 4))
    offset_panel(ax_z, work, 'z_G', np.geomspace(0.1, 12.0, 30), LEVERS_MM,
                 'lever z_G - z_B [mm]', 'G above the race')
    offset_panel(ax_t, work, 'tau', np.geomspace(0.1, 3.0, 30), LEANS_MRAD,
                 'lean tau of the principal axis [mrad]', 'leaning rotor axis (couple imbalance)')
    fig.suptitle('Residual tilt one race leaves, P3 (metal washers, mbar 0.03, wbar 2.7)')
    return save(fig, OUT / 'tilt_vs_offset.png')


def speed_figure(work: Path) -> str:
    plt = pyplot()
    params, _ = apply_settings(DriveParams(), {**P3, 'z_G': 1e-3})
    table = speed_bands.speed_table(params, 3.6 * params.omega0)
    wbar = np.linspace(1.05, 3.5, 60)
    stable = np.interp(wbar * params.omega0, table.omegas, table.lam_in) < 1.0
    tilt = [coupled.residual_tilt(params, w * params.omega0) * 1e3 if ok else np.nan
            for w, ok in zip(wbar, stable)]
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.semilogy(wbar, tilt, label='coupled linearisation (periodic response)')
    ax.semilogy(SPEEDS, [simulated_tilt(work, 'z_G=0.001', f'wbar={w}') * 1e3 for w in SPEEDS],
                'o', label='nonlinear run, 6 s (abb-sim run)')
    for band in table.bands:
        ax.axvspan(band.lo / params.omega0, band.hi / params.omega0, color='0.85',
                   label='unbalanced band (lam_max >= 1)' if band is table.bands[0] else None)
    ax.set_xlim(0.8, 3.5)
    ax.set_xlabel('spindle speed wbar')
    ax.set_ylabel('residual tilt [mrad]')
    ax.set_title('Residual tilt against speed, G 1 mm above the race (P3 drive)')
    ax.grid(alpha=0.3, which='both')
    ax.legend()
    return save(fig, OUT / 'tilt_vs_speed.png')


def main() -> int:
    OUT.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        print(offset_figure(Path(tmp)))
        print(speed_figure(Path(tmp)))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
