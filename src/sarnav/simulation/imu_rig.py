"""The multi-IMU rig of Sun (2022) and its world (extraction seed-003 §4, §8): the simulated flights over the
rotating Earth (:func:`climb_and_turn`, :func:`survey_flight`, :func:`cart_track`), IMUs with gnss-ins-sim's noise
semantics on lever arms (:func:`rig_imu`), absolute fixes with white and Gauss-Markov errors (:func:`simulate_fixes`,
:func:`correlated_fix_errors`), one aided particle filter per IMU (:func:`aided_pf`), the process noise derived from
an IMU's specifications (:func:`spec_accel_psd`) and the per-run random streams (:func:`seed_sequences`,
:func:`rngs_for`). The experiments that fly them are ``simulation.multi_imu`` (fusion, UPF flight) and
``simulation.nav_sources`` (per-pulse antenna positions); parameter choices where the source is silent are the
module constants, discussed in docs/particles.md.
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import InputDataError
from sarnav.filters.grid_particle import GridParticleFilter
from sarnav.filters.pulse_grid import FixStream, ImuStream, NavFrame
from sarnav.frames.wgs84 import ned_offset_to_geodetic
from sarnav.rotations import quat_to_dcm
from sarnav.sensors import ImuModel, imu_grade
from sarnav.sensors.gauss_markov import fogm_coefficients, fogm_path
from sarnav.sensors.lever_arm import lever_arm_specific_force, rate_derivative
from sarnav.trajectory import Maneuvering, RateProfile
from sarnav.trajectory.geodetic import GeodeticFlight

#: origin of the simulated flights: Norman, Oklahoma (the source's test area), 1000 m
ORIGIN = (np.radians(35.2), np.radians(-97.44), 1000.0)
#: fix (GPS) standard deviation per NED axis [m] (extraction §8 default; the source gives none, G8/G20)
FIX_SIGMA = np.array([0.3, 0.3, 0.5])
#: gnss-ins-sim draws a bias stability with infinite correlation time as white noise at every sample; an
#: FOGM with a correlation time far below the sample interval is that process (sarnav.sensors.imu docstring)
WHITE_BIAS_TAU = 1e-9
#: lever arms of the three ADIS16465 on the rig (body frame, metres from the reference point / GPS antenna)
ADIS_LEVER_ARMS = np.array([[0.10, 0.08, 0.0], [0.10, -0.08, 0.0], [-0.12, 0.0, 0.02]])
#: horizon [s] over which :func:`spec_accel_psd` lets the gyro-driven tilt error grow
SPEC_HORIZON = 100.0


def seed_sequences(seed, runs):
    """One SeedSequence per run: ``seed`` (int or SeedSequence) spawns ``runs`` children; a list of SeedSequences
    (a campaign's run seeds, ``sarnav.montecarlo.seeding.run_seeds``) is used as given, one per run."""
    if isinstance(seed, (list, tuple)):
        if len(seed) != runs or not all(isinstance(s, np.random.SeedSequence) for s in seed):
            raise InputDataError("seeds", f"need {runs} SeedSequences (one per run), got {len(seed)}")
        return list(seed)
    ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    return ss.spawn(runs)


def rngs_for(seqs, stream):
    """One Generator per run for a named stream (sensor noise, fixes, filter s, fusion) of that run."""
    return [np.random.default_rng(np.random.SeedSequence(s.entropy, spawn_key=s.spawn_key + (stream,)))
            for s in seqs]


def gnss_ins_sim_imu(name: str, rate: float) -> ImuModel:
    """An ImuModel of the named preset with gnss-ins-sim's semantics for the bias stability (white, G23)."""
    return ImuModel(imu_grade(name), rate, WHITE_BIAS_TAU, WHITE_BIAS_TAU)


def rig_imu(flight: GeodeticFlight, times, lever_arm, model: ImuModel, rngs) -> ImuStream:
    """Measured samples of an IMU at body offset ``lever_arm`` from the flight's reference point."""
    f, w = flight.imu(times)
    f = lever_arm_specific_force(f, w, rate_derivative(w, float(times[1] - times[0])), lever_arm)
    ba, bg = model.initial_biases(rngs)
    nu, om, *_ = model.measure(f, w, ba, bg, rngs)
    return ImuStream(times, nu, om)


def simulate_fixes(flight: GeodeticFlight, times, sigma, rngs, bias=(0.0, 0.0, 0.0)) -> FixStream:
    """Absolute fixes of the reference point: truth + bias + N(0, diag sigma^2) in NED metres, as geodetic."""
    s = flight.state(times)
    d = np.asarray(bias, dtype=float) + np.asarray(sigma) * np.stack([g.standard_normal((times.size, 3)) for g in rngs])
    lat, lon, h = ned_offset_to_geodetic(s.lat, s.lon, s.h, d)
    return FixStream(times, np.stack([lat, lon, h], -1), np.asarray(sigma, dtype=float))


def truth_native(flight, t):
    """The flight's reference point at ``t`` as (..., 3) [lat, lon, h] (rad, rad, m), and its full state."""
    s = flight.state(t)
    return np.stack([s.lat, s.lon, s.h], -1), s


def aided_pf(flight, imu, fixes, lever_arm, n_particles, accel_psd, rngs, out_times, t_end, model="geodetic"):
    """One aided PF per IMU (at ``lever_arm`` on the rig, aided by ``fixes``); returns its output translated to the
    reference point (R, T, 3) native [lat, lon, h] and the filter's ``GridOutput``."""
    frame = NavFrame(geodetic=True, origin=ORIGIN)
    s0 = flight.state(0.0)
    C0 = quat_to_dcm(s0.quaternion)
    lat, lon, h = ned_offset_to_geodetic(s0.lat, s0.lon, s0.h, C0 @ lever_arm)
    runs = imu.specific_force.shape[0]
    sig = fixes.sigma
    pf = GridParticleFilter(frame, n_particles, accel_psd, model=model, noise_at="fix", ess_threshold=0.5,
                            kernel_h=0.3, fix_lever_arm=-np.asarray(lever_arm, dtype=float))
    pf.initialize(0.0, np.broadcast_to([lat, lon, h], (runs, 3)), np.broadcast_to(s0.velocity, (runs, 3)),
                  s0.quaternion, np.diag(np.r_[sig**2, [0.05**2] * 3]), rngs)
    out = pf.run(imu, t_end, fixes, out_times)
    back = -np.einsum("rkij,j->rki", quat_to_dcm(out.quaternion), lever_arm)
    la, lo, hh = ned_offset_to_geodetic(out.position[..., 0], out.position[..., 1], out.position[..., 2], back)
    return np.stack([la, lo, hh], -1), out


def climb_and_turn(duration: float = 300.0, speed: float = 50.0) -> Maneuvering:
    """The multi-IMU flight (Fig. 5.9 "changes in latitude, longitude and altitude"): the built-in S-turn with
    climb and descent (``Maneuvering.s_turn_climb``)."""
    return Maneuvering.s_turn_climb([0.0, 0.0, -ORIGIN[2]], speed, np.radians(30.0), duration)


def spec_accel_psd(name: str, rate: float, horizon: float = SPEC_HORIZON) -> float:
    """White-acceleration PSD [m^2/s^3] for an aided PF from an IMU's specs (gap G16: "derived from the IMU
    specifications", L1145): the accelerometer white noise (VRW^2 plus gnss-ins-sim's white bias-stability
    term sigma_b^2 dt) plus the gyro-driven tilt error, g ARW sqrt(horizon) after ``horizon`` s, treated as
    white over ``horizon``: ``q = VRW^2 + sigma_b^2/rate + (g ARW horizon)^2``."""
    g = imu_grade(name)
    return float(g.vrw**2 + g.accel_bias**2 / rate + (9.81 * g.arw * horizon) ** 2)



def survey_flight(duration: float = 3600.0, speed: float = 50.0, climb: float = 3.0) -> Maneuvering:
    """A flight like the source's Piper Warrior sortie (L1273): climb (``climb`` m/s for the first 1/6), then
    figure-eights (a right and a left 360 deg turn at 3 deg/s) alternating with racetracks (straight 60 s,
    180 deg turn, straight 60 s, 180 deg turn), then a descent over the last 1/12. Transitions 4 s."""
    d = np.radians(3.0)
    starts, turn = [0.0], [0.0]
    t = duration / 12.0
    pattern = [(120.0, d), (120.0, -d), (30.0, 0.0), (60.0, 0.0), (60.0, d), (60.0, 0.0), (60.0, d), (30.0, 0.0)]
    i = 0
    while t + pattern[i % len(pattern)][0] < duration - 10.0:
        length, rate = pattern[i % len(pattern)]
        starts.append(t)
        turn.append(rate)
        t += length
        i += 1
    starts.append(t)
    turn.append(0.0)
    keep = np.concatenate([[True], np.diff(starts) >= 8.0])
    starts, turn = list(np.asarray(starts)[keep]), list(np.asarray(turn)[keep])
    c_starts = [0.0, duration / 6.0, 11.0 * duration / 12.0]
    return Maneuvering([0.0, 0.0, -ORIGIN[2]], speed, np.radians(200.0), RateProfile(tuple(starts), tuple(turn), 4.0),
                       RateProfile(tuple(c_starts), (climb, 0.0, -2.0 * climb), 4.0), duration)



def cart_track(duration: float, speed: float = 1.0, heading: float = np.pi / 2) -> Maneuvering:
    """The ground-test cart (§3.7 of the extraction): straight at ``speed`` m/s, level, at the origin height."""
    return Maneuvering([0.0, 0.0, -ORIGIN[2]], speed, heading, RateProfile((0.0,), (0.0,), 1.0),
                       RateProfile((0.0,), (0.0,), 1.0), duration)



def correlated_fix_errors(times, sigma, tau, rngs) -> np.ndarray:
    """(R, K, 3) first-order Gauss-Markov fix errors (stationary 1-sigma ``sigma`` (3,) [m], correlation time
    ``tau`` [s]; ``sensors.gauss_markov``, exact discretisation) at uniformly spaced ``times`` (K,): the slowly
    varying part of a GNSS position error (multipath, atmosphere, orbits)."""
    sigma = np.asarray(sigma, dtype=float)
    phi, drive = fogm_coefficients(sigma, tau, float(times[1] - times[0]) if len(times) > 1 else 1.0)
    b0 = sigma * np.stack([g.standard_normal(3) for g in rngs])
    w = np.stack([g.standard_normal((len(times) - 1, 3)) for g in rngs])
    path, last = fogm_path(b0, w, phi, drive)
    return np.concatenate([path, last[:, None]], axis=1)
