"""The ``spacecraft`` scenario kind: the open-loop Monte Carlo of Pogorelsky et al. 2022 §VI.B-VII (scenarios
``spacecraft-tc1``, ``spacecraft-tc2``; docs/spacecraft.md).

Configuration and wiring only; the physics is ``simulation.spacecraft.run_open_loop`` (truth orbit RK4 + J2, the
MEKF of ``filters.mekf`` at 100 Hz, the centre-pixel measurement of ``measurements.spacecraft``, Lear
underweighting of ``filters.underweighting``). The measurements are synthesised from the truth as the paper's open
loop does (r_f = boresight ∩ WGS-84 + N(0, D), range + N(0, 1 m^2), speed + N(0, 0.54^2)): the kind's only
measurement mode, named ``oracle`` (``[measurement] mode``) as the project's rule for truth-made measurements asks.
The closed loop from raw echoes is the ``spacecraft-closed-loop`` kind (``scenarios.spacecraft_closed_loop``).

Random draws: run i uses only ``Generator(PCG64(seeds[i]))`` in the order of ``run_open_loop`` (9 initial-error
normals, then 5 per update), so a run does not depend on the batch, the executor or the number of workers.
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
from sarnav.scenarios.fields import get as _get, table as _table
from sarnav.scenarios.fields import positive as _pos
from sarnav.simulation.spacecraft import OpenLoopParams, check_geometry, radial_intrack_crosstrack, run_open_loop
from sarnav.trajectory.orbit import MIN_PERIGEE_RADIUS, STEERING, table2_elements
from sarnav.frames.earth import WGS84_A

STATE_UNITS = ("m", "m", "m", "m/s", "m/s", "m/s", "rad", "rad", "rad")
MEAS_UNITS = ("1", "1", "m", "m/s")
RIC_NAMES = ("pR", "pI", "pC", "vR", "vI", "vC")
RIC_UNITS = ("m", "m", "m", "m/s", "m/s", "m/s")
BLOCK_NAMES = ("position", "velocity", "misalignment")
#: longest simulated flight [s] (one day: the truth orbit and the records are allocated up front)
MAX_DURATION = 86400.0
EXTRA_ATTRS = {
    "error_ric": {"units": "m, m/s (see ric_units)", "description": "position / velocity error in the radial, "
                  "in-track, cross-track frame of the true orbit (truth - estimate)"},
    "sigma_ric": {"units": "m, m/s (see ric_units)", "description": "filter 1-sigma in the radial, in-track, "
                  "cross-track frame (the ECEF covariance blocks rotated)"},
    "nees_block": {"units": "1", "description": "NEES of the position, velocity and misalignment blocks (3 dof each)"},
    "beta": {"units": "1", "description": "Lear underweighting factor beta applied at each update (0: none)"},
}


def _elements_table() -> dict:
    return {"altitude_km": 691.5,  # Table 2: altitude at the equator (a = R_e + 691.5 km)
            "inclination_deg": 98.16,  # Table 2
            "eccentricity": 0.00118,  # Table 2
            # G1 (not in the paper): ascending pass over 30.15 N 100 W at t = 0, so that the boresight lands near
            # Houston and the ground track reaches northern Canada after 10 min; frozen-orbit argument of perigee
            "latitude_deg": 30.15, "longitude_deg": -100.0, "argp_deg": 90.0}


def default_config(case: str = "tc2") -> dict:
    """TC-2 (misalignment 0.01 deg, no underweighting) or TC-1 (0.1 deg, beta 0.2 on 10 updates): Table 4, L514."""
    tc1 = case == "tc1"
    name = f"spacecraft-{case}"
    return {
        "scenario": {"name": name, "kind": "spacecraft",
                     "description": ("Pogorelsky et al. 2022 TC-1 open loop: misalignment 0.1 deg, Lear beta 0.2 on "
                                     "10 updates" if tc1 else "Pogorelsky et al. 2022 TC-2 open loop: misalignment "
                                     "0.01 deg, no underweighting")},
        "campaign": {"runs": 100, "seed": 20220901},  # 100 runs: L462
        "orbit": _elements_table(),
        "antenna": {"look_angle_deg": 34.3,  # G3: ALOS PALSAR nominal off-nadir angle, right-looking
                    "squint_deg": 0.0, "steering": "lvlh"},  # G3/G4: body = exact LVLH
        "simulation": {"duration": 600.0,  # 10 min (L484)
                       "update_interval": 8.2,  # L514
                       "n_updates": 0,  # 0: every t_k = 8.2 k <= duration (73, G11); 72 = the paper's count
                       "record_interval": 1.0, "truth_dt": 0.1},
        "initial": {"sigma_r0": 1000.0, "sigma_v0": 10.0,  # Table 4 [m, m/s per axis]
                    "sigma_mu0_deg": 0.1 if tc1 else 0.01},
        "measurement": {"mode": "oracle",  # the paper's open loop: measurements synthesised from the truth
                        "sigma_range": 1.0,  # Table 3 [m]
                        "sigma_vic": 0.54,  # Table 3 [m/s]
                        # G8: "2 to 8 m 1-sigma" per ECEF axis, values not given: 5^2 I m^2 (x-axis result depends on it)
                        "D": [[25.0, 0.0, 0.0], [0.0, 25.0, 0.0], [0.0, 0.0, 25.0]]},
        "mekf": {"q_accel": 3.5e-11, "q_misalignment": 3.4e-13,  # Q_PSD (L490)
                 "literal_q": True,  # G6: eq. 12 as printed
                 "coriolis": False,  # G7: eq. 13 without the Coriolis terms
                 "dt": 0.01,  # 100 Hz (L514)
                 "underweight_beta": 0.2 if tc1 else 0.0,  # L514: TC-1 only (0 disables)
                 "underweight_updates": 10},  # L514
        "truth": {"misalignment_psd": 0.0},  # G17/G18: the true misalignment is constant
    }


def tc1_config() -> dict:
    return default_config("tc1")


def tc2_config() -> dict:
    return default_config("tc2")


def read_elements(cfg: dict):
    """Keplerian elements of ``[orbit]`` (Table 2 + G1 keys); one-line errors for an orbit that hits the Earth or
    escapes."""
    ecc = require_finite("orbit.eccentricity", _get(cfg, "orbit", "eccentricity"), 0.0, None)
    if not ecc < 1.0:
        raise ConfigError("orbit.eccentricity", f"must be in [0, 1): e >= 1 escapes the Earth, got {ecc!r}")
    alt = units.km_to_m(require_finite("orbit.altitude_km", _get(cfg, "orbit", "altitude_km"), None, 1e6, "km"))
    perigee = (WGS84_A + alt) * (1.0 - ecc)
    if perigee < MIN_PERIGEE_RADIUS:
        raise ConfigError("orbit.altitude_km", f"the perigee radius (R_e + altitude)(1 - e) = {perigee:.0f} m is below "
                          f"{MIN_PERIGEE_RADIUS:.0f} m (R_e + 100 km): the orbit intersects the Earth")
    inc = require_finite("orbit.inclination_deg", _get(cfg, "orbit", "inclination_deg"), 0.0, 180.0, "deg")
    lat = require_finite("orbit.latitude_deg", _get(cfg, "orbit", "latitude_deg"), -90.0, 90.0, "deg")
    if abs(math.sin(math.radians(lat))) > abs(math.sin(math.radians(inc))) + 1e-12:
        raise ConfigError("orbit.latitude_deg", f"|latitude| must not exceed the inclination's reach "
                          f"({min(inc, 180 - inc):g} deg), got {lat!r}")
    lon = require_finite("orbit.longitude_deg", _get(cfg, "orbit", "longitude_deg"), -360.0, 360.0, "deg")
    argp = require_finite("orbit.argp_deg", _get(cfg, "orbit", "argp_deg"), -360.0, 360.0, "deg")
    rad = units.deg_to_rad
    return table2_elements(float(alt), float(rad(inc)), ecc, float(rad(lat)), float(rad(lon)), float(rad(argp)))


def read_noise(cfg: dict, table: str = "measurement") -> SarMeasurementNoise:
    """Range and speed 1-sigma and the centre-pixel covariance D of ``[table]``."""
    D = _get(cfg, table, "D")
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
    mk = _table(cfg, "mekf")
    qa = require_finite("mekf.q_accel", _get(cfg, "mekf", "q_accel"), 0.0, 1.0, "m^2/s^3")
    qm = require_finite("mekf.q_misalignment", _get(cfg, "mekf", "q_misalignment"), 0.0, 1.0, "rad^2/s")
    dt = _pos(cfg, "mekf", "dt", "s", lo=1e-4, hi=1.0)
    model = MekfModel(q_accel=qa, q_misalignment=qm, literal_q=_bool(cfg, "mekf", "literal_q"),
                      coriolis=_bool(cfg, "mekf", "coriolis"), dt=dt)
    beta = require_finite("mekf.underweight_beta", _get(cfg, "mekf", "underweight_beta"), 0.0, 1e3)
    n = mk.get("underweight_updates")
    if isinstance(n, bool) or not isinstance(n, int) or not 0 <= n <= 100_000:
        raise ConfigError("mekf.underweight_updates", f"must be an integer in [0, 100000], got {n!r}")
    return model, (LearUnderweighting(beta=beta, first_updates=n) if beta > 0 and n > 0 else None)


def parse_antenna(cfg: dict) -> dict:
    """``[antenna]`` as ``OpenLoopParams`` keywords (look angle, squint [rad], steering); closed loop too."""
    look = require_finite("antenna.look_angle_deg", _get(cfg, "antenna", "look_angle_deg"), 0.0, 89.0, "deg")
    squint = require_finite("antenna.squint_deg", _get(cfg, "antenna", "squint_deg"), -45.0, 45.0, "deg")
    steering = _get(cfg, "antenna", "steering")
    if steering not in STEERING:
        raise ConfigError("antenna.steering", f"must be one of {tuple(STEERING)}, got {steering!r}")
    return {"look_angle": float(units.deg_to_rad(look)), "squint": float(units.deg_to_rad(squint)),
            "steering": steering}


def parse_simulation(cfg: dict) -> dict:
    """``[simulation]`` as ``OpenLoopParams`` keywords (duration, intervals [s], n_updates); closed loop too."""
    dur = _pos(cfg, "simulation", "duration", "s", lo=0.01, hi=MAX_DURATION)
    n = _get(cfg, "simulation", "n_updates")
    if isinstance(n, bool) or not isinstance(n, int) or not 0 <= n <= 100_000:
        raise ConfigError("simulation.n_updates", f"must be an integer in [0, 100000] (0: every update), got {n!r}")
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
    mode = _get(cfg, "measurement", "mode")
    if mode != "oracle":
        raise ConfigError("measurement.mode", f"must be 'oracle' (the paper's open loop synthesises its measurements "
                          f"from the truth; images: kind 'spacecraft-closed-loop'), got {mode!r}")
    ini = {k: _pos(cfg, "initial", k, u, hi=hi) for k, u, hi in (("sigma_r0", "m", 1e7), ("sigma_v0", "m/s", 1e4))}
    ini["sigma_mu0"] = float(units.deg_to_rad(_pos(cfg, "initial", "sigma_mu0_deg", "deg", hi=10.0)))
    model, uw = read_mekf(cfg)
    psd = require_finite("truth.misalignment_psd", _get(cfg, "truth", "misalignment_psd"), 0.0, 1.0, "rad^2/s")
    params = OpenLoopParams(elements=read_elements(cfg), noise=read_noise(cfg), mekf=model, underweighting=uw,
                            truth_misalignment_psd=psd, **parse_antenna(cfg), **parse_simulation(cfg), **ini)
    check_geometry(params)
    return params


class SpacecraftKind(ScenarioKind):
    """Open-loop spacecraft SAR navigation Monte Carlo (module docstring)."""

    kind = "spacecraft"

    def default_config(self) -> dict:
        return default_config("tc2")

    def validate(self, cfg: dict) -> None:
        parse(cfg)

    def state_names(self, cfg: dict) -> list[str]:
        return list(STATE_NAMES)

    def state_units(self, cfg: dict) -> list[str]:
        return list(STATE_UNITS)

    def meas_names(self, cfg: dict) -> list[str]:
        return list(MEASUREMENT_NAMES)

    def meas_units(self, cfg: dict) -> list[str]:
        return list(MEAS_UNITS)

    def extra_attrs(self, cfg: dict) -> dict:
        return EXTRA_ATTRS

    def extra_coords(self, cfg: dict) -> dict:
        return {"ric": (list(RIC_NAMES), {"units": list(RIC_UNITS), "description": "radial, in-track, cross-track "
                                          "position and velocity of the true orbit"}),
                "block": (list(BLOCK_NAMES), {"units": "", "description": "error-state blocks of 3"})}

    def simulate(self, cfg: dict, run_ids, seeds) -> list[RunRecord]:
        if len(run_ids) != len(seeds):
            raise ConfigError("seeds", f"need one seed per run, got {len(seeds)} for {len(run_ids)} runs")
        if len(run_ids) == 0:
            return []
        return open_loop_records(run_open_loop(parse(cfg), list(seeds)), run_ids)

    def figures(self, results, outdir) -> list[str]:
        from sarnav.report.spacecraft_figures import write_spacecraft_figures

        return write_spacecraft_figures(results, outdir)


def open_loop_records(res, run_ids) -> list[RunRecord]:
    """One :class:`RunRecord` per run of an ``OpenLoopResult`` (extras: RIC errors and sigmas, block NEES, beta)."""
    err_ric, sig_ric = radial_intrack_crosstrack(res)
    out = []
    for i, rid in enumerate(run_ids):
        out.append(RunRecord(
            run=int(rid), time=res.time.copy(), error=res.error[i], sigma=res.sigma[i], nees=res.nees[i],
            update_time=res.update_time.copy(), residual=res.residual[i], residual_sigma=res.residual_sigma[i],
            nis=res.nis[i], nis_dof=np.full(res.update_time.size, 4, dtype=int),
            extras={"error_ric": (("time", "ric"), err_ric[i]), "sigma_ric": (("time", "ric"), sig_ric[i]),
                    "nees_block": (("time", "block"), res.nees_blocks[i]), "beta": (("update",), res.beta[i])}))
    return out

