"""Small helpers shared by the tests (import ``from helpers import ...``: tests/ is on ``sys.path``, see conftest.py).

spawn_rngs : per-run generators, child i of ``SeedSequence(seed)`` (the campaign's scheme, ``montecarlo.seeding``).
spawn_seeds : the children themselves.
nav_at : a NavState starting R runs exactly on one epoch of a truth state (zero IMU biases).
level_nav : a NavState at given positions and velocities with level attitude and zero IMU biases.
child_pids : process ids whose parent is a given pid (Linux /proc).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sarnav.ins.state import NavState


def spawn_seeds(n: int, seed: int = 0) -> list[np.random.SeedSequence]:
    """The ``n`` children of ``SeedSequence(seed)``."""
    return np.random.SeedSequence(seed).spawn(n)


def spawn_rngs(n: int, seed: int = 0) -> list[np.random.Generator]:
    """One generator per child of ``SeedSequence(seed)``: ``n`` independent streams."""
    return [np.random.default_rng(s) for s in spawn_seeds(n, seed)]


def nav_at(state, i: int = 0, runs: int = 1) -> NavState:
    """NavState of ``runs`` runs all at row ``i`` of the truth ``state`` (position, velocity, quaternion), zero
    accelerometer and gyro biases, no measurement biases."""
    rep = lambda a: np.repeat(a[i:i + 1], runs, axis=0)  # noqa: E731
    z = np.zeros((runs, 3))
    return NavState(rep(state.position), rep(state.velocity), rep(state.quaternion), z.copy(), z.copy())


def level_nav(p, v, bm=(0.0, 0.0, 0.0)) -> NavState:
    """NavState at positions ``p`` and velocities ``v`` ((R, 3) or (3,)), identity attitude, zero IMU biases and
    the measurement biases ``bm`` (K,) in every run (default three zeros: altimeter, range, cross-range)."""
    p, v = np.atleast_2d(p).astype(float), np.atleast_2d(v).astype(float)
    runs = p.shape[0]
    bm = np.tile(np.asarray(bm, dtype=float), (runs, 1))
    return NavState(p, v, np.tile([1.0, 0, 0, 0], (runs, 1)), np.zeros((runs, 3)), np.zeros((runs, 3)), bm)


def child_pids(pid: int) -> list[int]:
    """Process ids whose parent is ``pid`` (Linux /proc)."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out
