#!/usr/bin/env python3
"""Make the figures of steel balls with contact and rolling resistance.

The figures of docs/ball_size_contact_rolling.md and the numbers quoted there::

    .venv/bin/python scripts/make_ball_model_figures.py p1        # contact at P1 (~2 min)
    .venv/bin/python scripts/make_ball_model_figures.py rolling   # rbar vs rolling_mu (~15 min)
    .venv/bin/python scripts/make_ball_model_figures.py spinup    # spin-up trap (~10 min)
    .venv/bin/python scripts/make_ball_model_figures.py collision # energy ledger (~1 min)

Balls: solid steel of the scenario's mass
(abb_ros.model.parameters.ball_materials.with_steel_balls). Figures go to docs/figures/ball_model/;
tables are printed (Markdown).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys

import numpy as np

from abb_ros.app.headless import run_scenario
from abb_ros.io.files.scenario import load_scenario
from abb_ros.model.parameters.ball_materials import with_steel_balls
from abb_ros.model.stability.equilibrium import phi_star_two_balls

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FIG_DIR = os.path.join(ROOT, 'docs', 'figures', 'ball_model')
ROLLING_MU = (0.0, 1e-9, 1e-8, 1e-7, 1e-6, 3e-6, 1e-5)
"""Rolling-resistance coefficients of the P3 study [m]."""
STARTS_DEG = ((60.0, -60.0), (150.0, -150.0), (100.0, -140.0))
"""Initial ball angles of the P3 study [deg]: the paper's, and two from the far side."""
ACCELS = (250.0, 500.0, 1000.0, 2000.0, 4000.0)
"""Spindle acceleration limits of the spin-up study [rad/s^2]."""


def _steel(scenario, **kw):
    p = with_steel_balls(scenario.params, **kw)
    return dataclasses.replace(scenario, params=p)


def _rbar(result):
    p = result.scenario.params
    return np.sqrt((result.y[:, 1:4] ** 2).sum(axis=1)) / p.R


def _tail(x, t, seconds=1.0):
    return x[t >= t[-1] - seconds]


def _plt():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def study_p1():
    """P1 with and without contact: ball angles, separation, compression."""
    base = load_scenario('p1')
    paper = run_scenario(base)
    contact = run_scenario(_steel(base))
    p = contact.scenario.params
    phi = contact.y[:, 7:9]
    dphi = np.abs(((phi[:, 1] - phi[:, 0]) + math.pi) % (2 * math.pi) - math.pi)
    gap = 2 * p.R * np.sin(dphi / 2) - 2 * p.r_ball
    tail = _tail(dphi, contact.t)
    print(f'P1 steel balls: m = {p.m:g} kg, r_ball = {p.r_ball * 1e3:.4f} mm, '
          'predicted contact separation 2 asin(r/R) = '
          f'{math.degrees(p.contact_separation):.5f} deg')
    print(f'  separation over the last second: {np.degrees(tail.min()):.5f} .. '
          f'{np.degrees(tail.max()):.5f} deg')
    print(f'  minimum separation over the run: {np.degrees(dphi.min()):.5f} deg; largest '
          f'compression (2r - distance) {-gap.min() * 1e9:.3f} nm')
    print(f'  final angles paper {np.degrees(paper.y[-1, 7:9])} deg, contact '
          f'{np.degrees(phi[-1])} deg; final rbar paper {_rbar(paper)[-1]:.5f}, contact '
          f'{_rbar(contact)[-1]:.5f}; contact sub-steps: {contact.refined_steps} refined steps, '
          f'at most {contact.max_substeps} sub-steps; wall {contact.wall_time:.1f} s')
    plt = _plt()
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    for res, style, label in ((paper, '--', 'paper (point balls)'),
                              (contact, '-', 'steel balls, contact')):
        for i in (0, 1):
            ax[0].plot(res.t, np.degrees(res.y[:, 7 + i]), style, color=f'C{i}',
                       label=f'phi_{i + 1}, {label}')
    ax[0].set_xlabel('t [s]')
    ax[0].set_ylabel('ball angle [deg]')
    ax[0].set_title('P1 (wbar = 0.8): balls gather')
    ax[0].legend(fontsize=7)
    ax[1].plot(contact.t, np.degrees(dphi), label='phi_1 - phi_2 (contact)')
    ax[1].axhline(math.degrees(p.contact_separation), color='k', ls=':',
                  label='2 asin(r_ball / R)')
    ax[1].set_ylim(math.degrees(p.contact_separation) - 2, 125)
    ax[1].set_xlabel('t [s]')
    ax[1].set_ylabel('separation [deg]')
    ax[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(FIG_DIR, 'p1_contact.png'), dpi=110)


def study_rolling():
    """P3 with steel balls (contact) and rolling resistance: residual rbar and rest band."""
    base = load_scenario('p3')
    ratio = base.params.M * base.params.eps / (base.params.m * base.params.R)
    phi_star = math.degrees(phi_star_two_balls(ratio)[1])
    rows = []
    print(f'P3, phi* = +-{phi_star:.3f} deg; starts {STARTS_DEG} deg')
    print('| rolling_mu [m] | rbar residual (per start) | max abs(abs(phi) - phi*) [deg] '
          '| settled after [s] |')
    print('|---|---|---|---|')
    for mu in ROLLING_MU:
        rb, dev, settle = [], [], []
        for start in STARTS_DEG:
            sc = _steel(base, rolling_mu=mu)
            sc = dataclasses.replace(sc, phi0=np.radians(start))
            res = run_scenario(sc)
            r = _rbar(res)
            rb.append(float(_tail(r, res.t).max()))
            dev.append(float(np.abs(np.abs(np.degrees(res.y[-1, 7:9])) - phi_star).max()))
            rates = np.abs(res.y[:, 9 + 7:9 + 9]).max(axis=1)
            moving = np.flatnonzero(rates > 1e-3)
            settle.append(float(res.t[moving[-1]]) if moving.size else 0.0)
        rows.append((mu, rb, dev, settle))
        print(f'| {mu:g} | {", ".join(f"{v:.3g}" for v in rb)} | '
              f'{", ".join(f"{v:.3g}" for v in dev)} | {", ".join(f"{v:.2f}" for v in settle)} |',
              flush=True)
    plt = _plt()
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    mus = np.array([r[0] for r in rows[1:]])
    for k, start in enumerate(STARTS_DEG):
        ax[0].loglog(mus, [max(r[1][k], 1e-16) for r in rows[1:]], 'o-',
                     label=f'start {start[0]:g}, {start[1]:g} deg')
        ax[1].semilogx(mus, [r[2][k] for r in rows[1:]], 'o-',
                       label=f'start {start[0]:g}, {start[1]:g} deg')
    ax[0].axhline(1e-6, color='k', ls=':', label='1e-6')
    ax[0].set_xlabel('rolling_mu [m]')
    ax[0].set_ylabel('residual rbar (max over last s)')
    ax[0].set_title('P3 (wbar = 2.7), steel balls with contact')
    ax[0].legend(fontsize=7)
    ax[1].set_xlabel('rolling_mu [m]')
    ax[1].set_ylabel('max | |phi_i| - phi* | at rest [deg]')
    ax[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(FIG_DIR, 'rolling_residual.png'), dpi=110)


def _outcome(res):
    r = _rbar(res)
    tail = _tail(r, res.t)
    n = res.scenario.params.n
    N = 7 + n
    rates = np.abs(_tail(res.y[:, N + 7:N + 7 + n], res.t)).max()
    w = res.y[-1, N]
    if tail.max() < 1e-6:
        verdict = 'balanced'
    elif rates > 0.05 * w:
        verdict = 'trapped: balls orbit (non-synchronous whirl)'
    else:
        verdict = 'not balanced, balls at rest'
    return verdict, float(tail.max()), float(rates)


def study_spinup():
    """Run the P1 -> P3 run-up at several acceleration limits, paper vs steel balls touching."""
    base = load_scenario('spinup_p1_p3')
    print('| max_accel [rad/s^2] | model | outcome | rbar (max, last s) | max phi\' (last s) '
          '[rad/s] |')
    print('|---|---|---|---|---|')
    results = {}
    for acc in ACCELS:
        spindle = dataclasses.replace(base.spindle, max_accel=acc)
        for label, sc in (('paper', base), ('steel, contact', _steel(base))):
            sc = dataclasses.replace(sc, spindle=spindle)
            res = run_scenario(sc)
            verdict, rb, rate = _outcome(res)
            results[(acc, label)] = res
            print(f'| {acc:g} | {label} | {verdict} | {rb:.3g} | {rate:.3g} |', flush=True)
    plt = _plt()
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    for k, label in enumerate(('paper', 'steel, contact')):
        for acc in ACCELS:
            res = results[(acc, label)]
            ax[k].semilogy(res.t, np.maximum(_rbar(res), 1e-12), label=f'{acc:g} rad/s^2')
        ax[k].set_title(f'spin-up P1 -> P3: {label}')
        ax[k].set_xlabel('t [s]')
    ax[0].set_ylabel('rbar')
    ax[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(FIG_DIR, 'spinup_trap.png'), dpi=110)


def study_collision():
    """Run an elastic and a damped head-on impact on the clamped race.

    The elastic one shows the momentum, the damped one with rolling resistance the energy
    ledger; both go to collision_energy.png.
    """
    from abb_ros.model.dynamics.integrate import Simulation
    from abb_ros.model.dynamics.spindle import ConstantSpeed
    from abb_ros.model.parameters.ball_materials import clamped_race
    sys.path.insert(0, os.path.join(ROOT, 'test'))
    from race_ledger import collision_state, race_energy_ledger
    plt = _plt()
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    dt = 1e-7
    params = clamped_race()
    y0 = collision_state(params, 0.0, gap=1e-6, speed=0.05)
    sim = Simulation(params, 0.0, dt=dt, spindle=ConstantSpeed(), y0=y0)
    ys = np.concatenate([y0[None], sim.trajectory(1000, 1)])
    t = np.arange(len(ys)) * dt * 1e6
    v = ys[:, 16:18] * params.R
    p = params.m * params.R * v.sum(axis=1)
    print(f'elastic impact at 0.05 m/s, dt = {dt:g} s: speeds after {v[-1]} m/s; momentum '
          f'change {abs(p[-1] - p[0]) / p[0]:.2e} relative')
    ax[0].plot(t, v[:, 0], label='ball 1')
    ax[0].plot(t, v[:, 1], label='ball 2')
    ax[0].plot(t, p / (params.m * params.R) / 1, 'k:', label='momentum / (m R)')
    ax[0].set_xlabel('t [us]')
    ax[0].set_ylabel('R phi_i\' [m/s]')
    ax[0].set_title('clamped race, elastic Hertz impact')
    ax[0].legend(fontsize=7)
    params = clamped_race(rolling_mu=1e-5, contact_damping=0.5, D=5e-6)
    omega = 811.0
    y0 = collision_state(params, omega, gap=1e-6, speed=0.05)
    sim = Simulation(params, omega, dt=dt, spindle=ConstantSpeed(), y0=y0)
    ys = np.concatenate([y0[None], sim.trajectory(40000, 1)])
    led = race_energy_ledger(params, omega, ys, dt)
    ref = abs(led['input'][-1])
    scale = led['dissipated'][-1]
    t_ms = led['t'] * 1e3
    ax[1].plot(t_ms, (led['input'] - led['kinetic'] - led['potential']) / scale,
               label='input - kinetic - potential')
    ax[1].plot(t_ms, led['dissipated'] / scale, '--', label='dissipated')
    ax[1].plot(t_ms, led['potential'] / scale, label='contact potential')
    ax[1].plot(t_ms, led['residual'] / ref * 1e8, 'k', label='residual / |input| x 1e8')
    ax[1].set_xlabel('t [ms]')
    ax[1].set_ylabel('energy / dissipated energy')
    ax[1].set_title('811 rad/s, chi = 0.5 s/m, mu = 1e-5 m')
    ax[1].legend(fontsize=7)
    print(f'damped impact with rolling: input {led["input"][-1]:.6e} J, dissipated '
          f'{led["dissipated"][-1]:.6e} J, largest |residual| {np.abs(led["residual"]).max():.3e} '
          f'J = {np.abs(led["residual"]).max() / ref:.2e} of the input')
    fig.tight_layout()
    fig.savefig(os.path.join(FIG_DIR, 'collision_energy.png'), dpi=110)


def main(argv=None):
    """Run the study named on the command line; return the exit code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('study', choices=('p1', 'rolling', 'spinup', 'collision'))
    args = parser.parse_args(argv)
    os.makedirs(FIG_DIR, exist_ok=True)
    {'p1': study_p1, 'rolling': study_rolling, 'spinup': study_spinup,
     'collision': study_collision}[args.study]()
    return 0


if __name__ == '__main__':
    sys.exit(main())
