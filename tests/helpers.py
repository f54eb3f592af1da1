"""Small helpers shared by the tests (import ``from helpers import ...``: tests/ is on ``sys.path``, see conftest.py).

spawn_rngs : per-run generators, child i of ``SeedSequence(seed)`` (the campaign's scheme, ``montecarlo.seeding``).
spawn_seeds : the children themselves.
nav_at : a NavState starting R runs exactly on one epoch of a truth state (zero IMU biases).
level_nav : a NavState at given positions and velocities with level attitude and zero IMU biases.
child_pids : process ids whose parent is a given pid (Linux /proc).
straight_pulse_track : pulse times centred on 0 and antenna positions of a straight level flight north.
random_point_scene : an aperture north and random point targets at 30 deg depression (FFBP tests, bench_ffbp.py).
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


def straight_pulse_track(n_pulses: int, prf: float, speed: float, altitude: float):
    """(pulse times [s] centred on 0, antenna positions (n_pulses, 3) NED [m]) of a flight north at ``speed`` [m/s]
    and ``altitude`` [m] through the NED origin's vertical at t = 0."""
    times = (np.arange(n_pulses) - 0.5 * (n_pulses - 1)) / prf
    pos = np.zeros((n_pulses, 3))
    pos[:, 0] = speed * times
    pos[:, 2] = -altitude
    return times, pos


def random_point_scene(npx: int, p: int, slant: float, px: float, n_targets: int, seed: int, wavelength: float):
    """A track north and a square of ``npx`` x ``px`` m at ``slant`` [m] and 30 deg depression holding ``n_targets``
    random point targets (seeded): (antenna positions (p, 3) over the aperture for ``px`` azimuth resolution, target
    positions (n, 3), complex amplitudes (n,), ranges (p, n), the scene centre's east [m])."""
    alt, east = 0.5 * slant, slant * np.sqrt(0.75)
    aperture = wavelength * slant / (2 * px)
    pos = np.zeros((p, 3))
    pos[:, 0] = (np.arange(p) - p / 2) * aperture / p
    pos[:, 2] = -alt
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    w = npx * px
    tg = np.column_stack([rng.uniform(-w / 2, w / 2, n_targets), east + rng.uniform(-w / 2, w / 2, n_targets),
                          np.zeros(n_targets)])
    amp = rng.standard_normal(n_targets) + 1j * rng.standard_normal(n_targets)
    return pos, tg, amp, np.linalg.norm(tg[None] - pos[:, None], axis=2), east


def keep_saved_figures(monkeypatch, module) -> list:
    """The Figure objects ``module`` saves through its ``save_png`` (in order), still written by the real one: a
    figure test reads the drawn data back from the artists."""
    figs = []
    real = module.save_png

    def keep(fig, path, *a, **k):
        figs.append(fig)
        return real(fig, path, *a, **k)

    monkeypatch.setattr(module, "save_png", keep)
    return figs


def assert_png(path, min_bytes: int = 2000) -> None:
    """``path`` is a PNG file (its signature) of at least ``min_bytes``."""
    from pathlib import Path

    p = Path(path)
    assert p.is_file() and p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > min_bytes


def assert_one_line_error(capsys, code, *words) -> None:
    """The CLI's exit ``code`` is 2 and stderr is one line ``sarnav: error: ...`` (no traceback) holding ``words``."""
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("sarnav: error: ") and err.count("\n") == 1 and "Traceback" not in err, err
    assert all(w in err for w in words), err


def packaged_toml(name: str) -> dict:
    """The packaged default configuration of scenario ``name`` read straight from its TOML file with ``tomllib`` (an
    independent reading, beside ``scenarios.registry.packaged``)."""
    import tomllib
    from importlib import resources

    return tomllib.loads(resources.files("sarnav.scenarios").joinpath("defaults", f"{name}.toml").read_text("utf-8"))


def packaged_with(name: str, **changes) -> dict:
    """``scenarios.registry.packaged(name)`` with ``table__key=value`` changes (``None`` deletes the key)."""
    import copy

    from sarnav.scenarios.registry import packaged

    cfg = copy.deepcopy(packaged(name))
    for k, v in changes.items():
        table, key = k.split("__")
        if v is None:
            cfg[table].pop(key, None)
        else:
            cfg[table][key] = v
    return cfg
