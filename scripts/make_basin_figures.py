"""Make the figures of docs/basin.md: the validation cases of `abb-sim basin`.

Every case is an ``abb-sim basin`` study run through the command line on one local Dask
cluster (2 workers), into ``WORK/<case>`` (resumed when it is already there); the figures go
to docs/figures/basin/ and the numbers to docs/figures/basin/cases.json.

Usage: ``.venv/bin/python scripts/make_basin_figures.py [--work DIR] [--only CASE ...]``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import shutil
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ROOT / 'docs' / 'figures' / 'basin'
STEEL = ['r_ball=2.3559716663050265e-3', 'contact_E=2e11']   # steel balls of m = 0.43 g

CASES = {
    # P3 without rolling resistance (the benchmark's study: same arguments)
    'p3': ['--res', '32x32', '--duration', '3'],
    # the same drive from uniform random starts: two balls, and three balls (n >= 3 family)
    'p3_samples': ['--samples', '256', '--seed', '1', '--duration', '3'],
    'p3_n3_samples': ['--set', 'n=3', '--samples', '256', '--seed', '1', '--duration', '3'],
    # in the unbalanced band below the first resonances
    'band_wbar0.9': ['--res', '12x12', '--duration', '3', '--set', 'wbar=0.9'],
    # steel balls with contact, rolling resistance off and on
    'steel_mu0': ['--res', '12x12', '--duration', '3', *sum((['--set', s] for s in STEEL), [])],
    'steel_mu1e-6': ['--res', '12x12', '--duration', '3',
                     *sum((['--set', s] for s in STEEL + ['rolling_mu=1e-6']), [])],
    'steel_mu3e-6': ['--res', '12x12', '--duration', '3',
                     *sum((['--set', s] for s in STEEL + ['rolling_mu=3e-6']), [])],
    # speed profiles: constant P3 speed, a direct motor run-up, a run-up with a plateau at P1
    'profile_constant': ['--res', '12x12', '--duration', '4'],
    'profile_direct': ['--scenario', str(ROOT / 'config' / 'scenarios' / 'runup_direct_p3.yaml'),
                       '--res', '12x12', '--duration', '4'],
    'profile_plateau': ['--scenario', 'spinup_p1_p3', '--res', '12x12', '--duration', '4'],
}
for _name, _scenario in (('constant', 'p3'), ('direct', str(ROOT / 'config' / 'scenarios' /
                                                           'runup_direct_p3.yaml')),
                         ('plateau', 'spinup_p1_p3')):
    # the same three profiles with steel balls and rolling resistance 1e-6 m
    CASES[f'profile_{_name}_mu1e-6'] = [
        '--scenario', _scenario, '--res', '10x10', '--duration', '4',
        *sum((['--set', s] for s in STEEL + ['rolling_mu=1e-6']), [])]
SPEEDS = [0.6, 0.9, 1.2, 1.5, 1.8, 2.0, 2.25, 2.7, 3.2, 4.0]
for _w in SPEEDS:
    CASES[f'speed_{_w:g}'] = ['--res', '8x8', '--duration', '3', '--set', f'wbar={_w:g}']


def run_case(name: str, work: Path, address: str) -> dict:
    """Run (or resume) one case; return its summary."""
    from abb_ros.cli import main
    out = work / name
    argv = ['basin', *CASES[name], '--out', str(out), '--scheduler', address, '--resume',
            '--no-progress', '--json']
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(argv)
    if code != 0:
        raise SystemExit(f'abb-sim {" ".join(argv)} exited {code}')
    summary = json.loads(buf.getvalue())
    print(f'{name}: P = {summary["balanced_fraction"]:.3f} {summary["ci95"]} '
          f'{summary["outcomes"]} Floquet {summary["floquet"].get("verdict")}', flush=True)
    return summary


def _plt():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def _table(work, name):
    import pyarrow.parquet as pq
    return pq.read_table(work / name / 'basin.parquet').to_pydict()


def _save(plt, fig, name):
    fig.tight_layout()
    fig.savefig(FIGURES / name, dpi=110)
    plt.close(fig)


def _bars(ax, results, names, labels, ylabel):
    """P(balance) of each case as a bar with its 95 % Wilson interval."""
    for i, name in enumerate(names):
        p = results[name]['balanced_fraction']
        lo, hi = results[name]['ci95']
        ax.bar(i, p, yerr=[[p - lo], [hi - p]], capsize=6, color='#2ca02c')
    ax.set_xticks(range(len(names)), labels, fontsize=8)
    ax.set_ylabel(ylabel)
    ax.set_ylim(0, 1.05)


def rolling_figure(work: Path, results: dict) -> None:
    """P(balance) per rolling_mu, and where the balls came to rest."""
    plt = _plt()
    names = ['steel_mu0', 'steel_mu1e-6', 'steel_mu3e-6']
    labels = ['0', '1e-6 m', '3e-6 m']
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    _bars(a, results, names, labels, 'P(balance), 95 % Wilson interval')
    a.set_xlabel('rolling_mu')
    star = results['steel_mu0']['floquet']['phi_star_deg'][1]
    bins = np.linspace(-30, 30, 61)
    for name, label in zip(names, labels):
        t = _table(work, name)
        rest = [o not in ('moving', 'failed', 'overlap') for o in t['outcome']]
        off = [abs(v) - star for r, v1, v2 in zip(rest, t['phi1_final_deg'], t['phi2_final_deg'])
               if r for v in (v1, v2)]
        b.hist(off, bins=bins, histtype='step', lw=1.5, label=f'rolling_mu {label}')
    b.set_xlabel('|final phi| - phi* [deg] (balls at rest)')
    b.set_ylabel('balls')
    b.legend(fontsize=8)
    fig.suptitle('P3, steel balls with contact, 12 x 12 starts of 3 s', fontsize=9)
    _save(plt, fig, 'rolling.png')


def profile_figure(results: dict) -> None:
    """P(balance) for the three speed profiles, point masses and steel balls with friction."""
    plt = _plt()
    names = ['profile_constant', 'profile_direct', 'profile_plateau']
    labels = ['constant P3 speed', 'direct run-up\n(motor, 0 -> P3)',
              'run-up with 1 s plateau\nat wbar 0.8 (spinup_p1_p3)']
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    _bars(a, results, names, labels, 'P(balance) after 4 s, 95 % Wilson interval')
    a.set_title('point-mass balls, 12 x 12 starts', fontsize=9)
    _bars(b, results, [f'{n}_mu1e-6' for n in names], labels, '')
    b.set_title('steel balls with contact, rolling_mu 1e-6 m, 10 x 10 starts', fontsize=9)
    fig.suptitle('P3 drive: speed profile against P(balance)', fontsize=9)
    _save(plt, fig, 'profiles.png')


def speed_figure(results: dict) -> None:
    """|lambda|max against speed above, P(balance) against speed below."""
    from abb_ros.io.files.scenario import load_scenario
    from abb_ros.model.stability.floquet import sweep_speed
    plt = _plt()
    p = load_scenario('p3').params
    w = np.linspace(0.3, 4.2, 300)
    lam_in = sweep_speed(p, w * p.omega0, 'in')
    lam_out = sweep_speed(p, w * p.omega0, 'out')
    fig, (a, b) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    a.plot(w, lam_in, label='in-plane')
    a.plot(w, lam_out, label='out-of-plane')
    a.axhline(1.0, color='k', lw=0.8)
    a.set_ylabel('|lambda|max')
    a.legend(fontsize=8)
    a.set_title('P3 drive (mbar 0.03, metal washers): local verdict and P(balance)', fontsize=9)
    ps = [results[f'speed_{x:g}'] for x in SPEEDS]
    b.errorbar(SPEEDS, [s['balanced_fraction'] for s in ps],
               yerr=np.array([[s['balanced_fraction'] - s['ci95'][0] for s in ps],
                              [s['ci95'][1] - s['balanced_fraction'] for s in ps]]),
               fmt='o', capsize=4)
    b.set_ylim(-0.05, 1.05)
    b.set_xlabel('wbar')
    b.set_ylabel('P(balance), 8 x 8 starts, 3 s')
    _save(plt, fig, 'p_vs_speed.png')


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--work', default='/tmp/basin_runs')
    parser.add_argument('--only', action='append', choices=sorted(CASES))
    args = parser.parse_args(argv)
    from distributed import Client

    from abb_ros.sweep.runner import local_cluster
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    FIGURES.mkdir(parents=True, exist_ok=True)
    results = {}
    with local_cluster(2) as cluster, Client(cluster) as client:
        for name in args.only or CASES:
            results[name] = run_case(name, work, client.scheduler.address)
    print('load average %.2f %.2f %.2f' % os.getloadavg(), file=sys.stderr)
    if args.only:
        return 0
    shutil.copy(work / 'p3' / 'basin.png', FIGURES / 'p3_grid.png')
    shutil.copy(work / 'band_wbar0.9' / 'basin.png', FIGURES / 'band_wbar0.9.png')
    shutil.copy(work / 'p3_n3_samples' / 'basin.png', FIGURES / 'p3_n3_samples.png')
    shutil.copy(work / 'steel_mu3e-6' / 'basin.png', FIGURES / 'steel_mu3e-6.png')
    shutil.copy(work / 'profile_plateau' / 'basin.png', FIGURES / 'profile_plateau.png')
    rolling_figure(work, results)
    profile_figure(results)
    speed_figure(results)
    keep = ('runs', 'balanced', 'balanced_fraction', 'ci95', 'outcomes', 'floquet_balanced')
    cases = {name: {k: s[k] for k in keep} | {'lam': [s['floquet'].get('lam_in'),
                                                      s['floquet'].get('lam_out')]}
             for name, s in results.items()}
    (FIGURES / 'cases.json').write_text(json.dumps(cases, indent=1) + '\n')
    return 0 if all(math.isfinite(s['balanced_fraction']) for s in results.values()) else 1


if __name__ == '__main__':
    sys.exit(main())
