"""The ``spacecraft`` scenario kind: the open-loop Monte Carlo of Pogorelsky et al. 2022 §VI.B-VII (scenarios
``spacecraft-tc1``, ``spacecraft-tc2``; docs/spacecraft.md).

Configuration and wiring only; the experiment is ``simulation.spacecraft.run_open_loop_records`` (truth orbit RK4 + J2,
the MEKF of ``filters.mekf``, the centre-pixel measurement of ``measurements.spacecraft``, Lear underweighting). The
measurements are synthesised from the truth as the paper's open loop does: the kind's only measurement mode, named
``oracle`` (``[measurement] mode``). The closed loop from raw echoes is ``scenarios.spacecraft_closed_loop``.
"""

from __future__ import annotations

import math

import numpy as np

from sarnav import units
from sarnav.errors import ConfigError, require_finite
from sarnav.filters.mekf import STATE_NAMES, MekfModel
from sarnav.filters.underweighting import LearUnderweighting
from sarnav.measurements.spacecraft import MEASUREMENT_NAMES, SarMeasurementNoise
from sarnav.montecarlo.kind import ScenarioKind, validate_campaign
from sarnav.montecarlo.record import RunRecord
from sarnav.scenarios.fields import boolean as _bool
from sarnav.scenarios.fields import choice, get, integer, number
from sarnav.scenarios.fields import positive as _pos
from sarnav.scenarios.kind_base import one_seed_per_run
from sarnav.scenarios.registry import packaged
from sarnav.simulation.spacecraft import BLOCK_NAMES, MEAS_UNITS, RIC_NAMES, RIC_UNITS, STATE_UNITS, OpenLoopParams, \
    check_geometry, run_open_loop_records
from sarnav.simulation.spacecraft import OPEN_LOOP_ATTRS as EXTRA_ATTRS
from sarnav.trajectory.orbit import MIN_PERIGEE_RADIUS, STEERING, KeplerElements
from sarnav.frames.earth import WGS84_A

#: longest simulated flight [s] (one day: the truth orbit and the records are allocated up front)
MAX_DURATION = 86400.0


def read_elements(cfg: dict):
    """Keplerian elements of ``[orbit]`` (Table 2 + G1 keys); one-line errors for an orbit that hits the Earth or
    escapes."""
    ecc = number(cfg, "orbit", "eccentricity", 0.0, None)
    if not ecc < 1.0:
        raise ConfigError("orbit.eccentricity", f"must be in [0, 1): e >= 1 escapes the Earth, got {ecc!r}")
    alt = units.km_to_m(number(cfg, "orbit", "altitude_km", None, 1e6, "km"))
    perigee = (WGS84_A + alt) * (1.0 - ecc)
    if perigee < MIN_PERIGEE_RADIUS:
        raise ConfigError("orbit.altitude_km", f"the perigee radius (R_e + altitude)(1 - e) = {perigee:.0f} m is below "
                          f"{MIN_PERIGEE_RADIUS:.0f} m (R_e + 100 km): the orbit intersects the Earth")
    inc = number(cfg, "orbit", "inclination_deg", 0.0, 180.0, "deg")
    lat = number(cfg, "orbit", "latitude_deg", -90.0, 90.0, "deg")
    if abs(math.sin(math.radians(lat))) > abs(math.sin(math.radians(inc))) + 1e-12:
        raise ConfigError("orbit.latitude_deg", f"|latitude| must not exceed the inclination's reach "
                          f"({min(inc, 180 - inc):g} deg), got {lat!r}")
    lon = number(cfg, "orbit", "longitude_deg", -360.0, 360.0, "deg")
    argp = number(cfg, "orbit", "argp_deg", -360.0, 360.0, "deg")
    rad = units.deg_to_rad
    return KeplerElements.table2(float(alt), float(rad(inc)), ecc, float(rad(lat)), float(rad(lon)), float(rad(argp)))


def read_noise(cfg: dict, table: str = "measurement") -> SarMeasurementNoise:
    """Range and speed 1-sigma and the centre-pixel covariance D of ``[table]``."""
    D = get(cfg, table, "D")
    if (not isinstance(D, list) or len(D) != 3 or not all(isinstance(row, list) and len(row) == 3 for row in D)):
        raise ConfigError(f"{table}.D", f"must be a 3 x 3 list of lists [m^2] (ECEF covariance), got {D!r}")
    vals = np.array([[require_finite(f"{table}.D[{i}][{j}]", x, -1e12, 1e12, "m^2") for j, x in enumerate(row)]
                     for i, row in enumerate(D)])
    sr = _pos(cfg, table, "sigma_range", "m", hi=1e5)
    sv = _pos(cfg, table, "sigma_vic", "m/s", hi=1e3)
    try:
        noise = SarMeasurementNoise(sigma_range=sr, sigma_vic=sv, D=vals)
    except ConfigError as err:
        raise ConfigError(f"{table}.D", err.message) from None
    if np.min(np.diag(noise.D)) < 1e-12:
        raise ConfigError(f"{table}.D", "must be positive definite with variances >= 1e-12 m^2")
    return noise


def read_mekf(cfg: dict) -> tuple[MekfModel, LearUnderweighting | None]:
    qa = number(cfg, "mekf", "q_accel", 0.0, 1.0, "m^2/s^3")
    qm = number(cfg, "mekf", "q_misalignment", 0.0, 1.0, "rad^2/s")
    dt = _pos(cfg, "mekf", "dt", "s", lo=1e-4, hi=1.0)
    model = MekfModel(q_accel=qa, q_misalignment=qm, literal_q=_bool(cfg, "mekf", "literal_q"),
                      coriolis=_bool(cfg, "mekf", "coriolis"), dt=dt)
    beta = number(cfg, "mekf", "underweight_beta", 0.0, 1e3)
    n = integer(cfg, "mekf", "underweight_updates", 0, 100_000)
    return model, (LearUnderweighting(beta=beta, first_updates=n) if beta > 0 and n > 0 else None)


def read_antenna(cfg: dict) -> dict:
    """``[antenna]`` as OpenLoopParams fields (look angle and squint [rad], steering)."""
    look = number(cfg, "antenna", "look_angle_deg", 0.0, 89.0, "deg")
    squint = number(cfg, "antenna", "squint_deg", -45.0, 45.0, "deg")
    steering = choice(cfg, "antenna", "steering", STEERING)
    return {"look_angle": float(units.deg_to_rad(look)), "squint": float(units.deg_to_rad(squint)),
            "steering": steering}


def read_initial(cfg: dict, r_max: float, v_max: float, mu_max_deg: float) -> dict:
    """``[initial]`` 1-sigma per axis (Table 4) as OpenLoopParams fields: position [m] up to ``r_max``, velocity [m/s]
    up to ``v_max``, misalignment (``sigma_mu0_deg`` up to ``mu_max_deg``) [rad]."""
    ini = {k: _pos(cfg, "initial", k, u, hi=hi) for k, u, hi in (("sigma_r0", "m", r_max), ("sigma_v0", "m/s", v_max))}
    ini["sigma_mu0"] = float(units.deg_to_rad(_pos(cfg, "initial", "sigma_mu0_deg", "deg", hi=mu_max_deg)))
    return ini


def read_simulation(cfg: dict) -> dict:
    """``[simulation]`` as OpenLoopParams fields (SI; ``n_updates`` None: every update)."""
    dur = _pos(cfg, "simulation", "duration", "s", lo=0.01, hi=MAX_DURATION)
    n = integer(cfg, "simulation", "n_updates", 0, 100_000, " (0: every update)")
    rec = _pos(cfg, "simulation", "record_interval", "s", lo=0.01, hi=MAX_DURATION)
    if dur / rec > 200_000:
        raise ConfigError("simulation.record_interval", f"gives {dur / rec:.3g} records per run (at most 200000)")
    return {"duration": dur, "update_interval": _pos(cfg, "simulation", "update_interval", "s", lo=0.01,
                                                      hi=MAX_DURATION),
            "n_updates": None if n == 0 else n, "record_interval": rec,
            "truth_dt": _pos(cfg, "simulation", "truth_dt", "s", lo=0.01, hi=10.0)}


def parse(cfg: dict) -> OpenLoopParams:
    """Validate ``cfg`` and convert to SI; ConfigError names the first bad field and its range."""
    validate_campaign(cfg)
    mode = get(cfg, "measurement", "mode")
    if mode != "oracle":
        raise ConfigError("measurement.mode", f"must be 'oracle' (the paper's open loop synthesises its measurements "
                          f"from the truth; images: kind 'spacecraft-closed-loop'), got {mode!r}")
    ini = read_initial(cfg, 1e7, 1e4, 10.0)
    model, uw = read_mekf(cfg)
    psd = number(cfg, "truth", "misalignment_psd", 0.0, 1.0, "rad^2/s")
    params = OpenLoopParams(elements=read_elements(cfg), noise=read_noise(cfg), mekf=model, underweighting=uw,
                            truth_misalignment_psd=psd, **read_antenna(cfg), **read_simulation(cfg), **ini)
    check_geometry(params)
    return params


class SpacecraftKind(ScenarioKind):
    """Open-loop spacecraft SAR navigation Monte Carlo (module docstring); the closed loop's kind changes its
    ``kind``, ``parse``, ``run_records`` and ``attrs``."""

    kind, scenario = "spacecraft", "spacecraft-tc2"
    parse, run_records, attrs = staticmethod(parse), staticmethod(run_open_loop_records), EXTRA_ATTRS

    def default_config(self) -> dict:
        return packaged(self.scenario)

    def validate(self, cfg: dict) -> None:
        self.parse(cfg)

    def state_names(self, cfg: dict) -> list[str]:
        return list(STATE_NAMES)

    def state_units(self, cfg: dict) -> list[str]:
        return list(STATE_UNITS)

    def meas_names(self, cfg: dict) -> list[str]:
        return list(MEASUREMENT_NAMES)

    def meas_units(self, cfg: dict) -> list[str]:
        return list(MEAS_UNITS)

    def extra_attrs(self, cfg: dict) -> dict:
        return self.attrs

    def extra_coords(self, cfg: dict) -> dict:
        return {"ric": (list(RIC_NAMES), {"units": list(RIC_UNITS), "description": "radial, in-track, cross-track "
                                          "position and velocity of the true orbit"}),
                "block": (list(BLOCK_NAMES), {"units": "", "description": "error-state blocks of 3"})}

    def simulate(self, cfg: dict, run_ids, seeds) -> list[RunRecord]:
        one_seed_per_run(run_ids, seeds)
        if len(run_ids) == 0:
            return []
        return self.run_records(self.parse(cfg), list(seeds), run_ids)

    def figures(self, results, outdir) -> list[str]:
        from sarnav.report.spacecraft_figures import write_spacecraft_figures

        return write_spacecraft_figures(results, outdir)
