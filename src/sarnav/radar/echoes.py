"""Raw echo simulation: stop-and-hop, complex baseband LFM, two-way azimuth pattern, noise.

For pulse p at antenna position x_p and scatterer k at y_k with amplitude a_k (architecture §3,
Cumming & Wong 2005 eq. 4.38, paper eq. (2) with tau = 2R/c):

    s_p(t_i) = sum_k a_k G_pk rect((t_i - tau_pk)/T) exp(-j 4 pi f_c R_pk / c) exp(j pi K (t_i - tau_pk)^2)

R_pk = |y_k - x_p| (float64), tau_pk = 2 R_pk / c, t_i = 2 near_range / c + i / fs (fast time from
the transmit instant of the pulse centre, stop-and-hop: the platform does not move during a pulse).
G_pk is the two-way amplitude pattern ``sinc^2(L sin(theta)/lambda)`` (:mod:`sarnav.radar.antenna`;
boresight perpendicular to the velocity, on the look side, zero squint; 0 on the other side).
No range spreading loss and no elevation pattern.

Noise (``snr_db``): circular complex white Gaussian noise of power sigma^2 = E|n|^2 per sample
(sigma^2/2 per real/imaginary part), defined by the **per-sample SNR of the strongest scatterer on
boresight**: sigma^2 = max_k |a_k|^2 / 10^(snr_db/10). After the unweighted matched filter the peak
SNR is higher by the time-bandwidth gain 10 log10(M), M = number of replica samples (~T fs).

Compiled kernel: numba ``@njit(parallel=True, cache=True)``, ``prange`` over pulses; accumulation in
complex128; output complex128 (or ``dtype=np.complex64`` on request).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numba import njit, prange

from sarnav.errors import ConfigError, InputDataError
from sarnav.signal.data import PulseData
from sarnav.radar.antenna import along_track_directions, look_vectors
from sarnav.radar.scene import Scene
from sarnav.units import C, db_to_power


#: exact phase evaluation every RESEED samples, recurrence in between (agrees with direct
#: evaluation to ~1e-9 of the peak amplitude: benchmarks/bench_echoes.py, tests/test_echoes.py)
RESEED = 64


@njit(parallel=True, cache=True)
def _echo_kernel(positions, along, look, targets, amps, t0, fs, fc, chirp_rate, pulse_length,
                 antenna_length, wavelength, use_pattern, out):
    n_pulses = positions.shape[0]
    n_targets = targets.shape[0]
    n_samples = out.shape[1]
    half_t = 0.5 * pulse_length
    ph_q = 2.0 * math.pi * chirp_rate / (fs * fs)
    q = complex(math.cos(ph_q), math.sin(ph_q))
    for p in prange(n_pulses):
        for k in range(n_targets):
            dx = targets[k, 0] - positions[p, 0]
            dy = targets[k, 1] - positions[p, 1]
            dz = targets[k, 2] - positions[p, 2]
            r = math.sqrt(dx * dx + dy * dy + dz * dz)
            g = 1.0
            if use_pattern:
                side = dx * look[p, 0] + dy * look[p, 1] + dz * look[p, 2]
                if side <= 0.0:
                    continue
                u = antenna_length * (dx * along[p, 0] + dy * along[p, 1] + dz * along[p, 2]) / (r * wavelength)
                if u != 0.0:
                    s = math.sin(math.pi * u) / (math.pi * u)
                    g = s * s
            tau = 2.0 * r / C
            i0 = int(math.ceil((tau - half_t - t0) * fs))
            i1 = int(math.floor((tau + half_t - t0) * fs))
            if i0 < 0:
                i0 = 0
            if i1 > n_samples - 1:
                i1 = n_samples - 1
            carrier = -4.0 * math.pi * fc * r / C
            a = amps[k] * g * complex(math.cos(carrier), math.sin(carrier))
            # chirp phase pi K dt^2 by a second-order recurrence (z_{i+1} = z_i w_i,
            # w_{i+1} = w_i q, q = exp(j 2 pi K / fs^2)), re-seeded exactly every RESEED samples
            i = i0
            while i <= i1:
                dt = t0 + i / fs - tau
                ph = math.pi * chirp_rate * dt * dt
                z = a * complex(math.cos(ph), math.sin(ph))
                ph_w = math.pi * chirp_rate * (2.0 * dt / fs + 1.0 / (fs * fs))
                w = complex(math.cos(ph_w), math.sin(ph_w))
                stop = min(i + RESEED, i1 + 1)
                for j in range(i, stop):
                    out[p, j] += z
                    z *= w
                    w *= q
                i = stop


@njit(parallel=True, cache=True)
def _range_extent(positions, targets):
    """(K,) min and max distance of every target over all antenna positions."""
    n_targets = targets.shape[0]
    rmin = np.empty(n_targets)
    rmax = np.empty(n_targets)
    for k in prange(n_targets):
        lo = np.inf
        hi = -np.inf
        for p in range(positions.shape[0]):
            dx = targets[k, 0] - positions[p, 0]
            dy = targets[k, 1] - positions[p, 1]
            dz = targets[k, 2] - positions[p, 2]
            r = math.sqrt(dx * dx + dy * dy + dz * dz)
            lo = min(lo, r)
            hi = max(hi, r)
        rmin[k] = lo
        rmax[k] = hi
    return rmin, rmax


def _check_inputs(positions, pulse_times, scene):
    pos = np.asarray(positions, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[1] != 3 or pos.shape[0] < 1:
        raise InputDataError("positions", f"must have shape (P, 3) with P >= 1, got {np.shape(positions)}")
    if not np.all(np.isfinite(pos)):
        raise InputDataError("positions", "contains NaN or inf")
    t = np.asarray(pulse_times, dtype=np.float64)
    if t.shape != (pos.shape[0],):
        raise InputDataError("pulse_times", f"must have shape ({pos.shape[0]},) matching positions, got {t.shape}")
    if not np.all(np.isfinite(t)):
        raise InputDataError("pulse_times", "contains NaN or inf")
    if t.size > 1 and np.any(np.diff(t) <= 0):
        raise InputDataError("pulse_times", "must be strictly increasing")
    if not isinstance(scene, Scene):
        raise InputDataError("scene", f"must be a sarnav.radar.scene.Scene, got {type(scene).__name__}")
    return np.ascontiguousarray(pos), np.ascontiguousarray(t)


def _add_noise(out: np.ndarray, amplitude: float, snr_db, rng) -> float:
    """Add circular complex white Gaussian noise in place; per-sample SNR of ``amplitude`` (module doc)."""
    if snr_db is None or isinstance(snr_db, bool) or not np.isfinite(snr_db):
        raise ConfigError("snr_db", f"must be finite [dB], got {snr_db!r}")
    if not isinstance(rng, np.random.Generator):
        raise ConfigError("rng", "a numpy.random.Generator is required when snr_db is given")
    noise_power = float(amplitude**2 / db_to_power(snr_db))
    # (..., 2) normals viewed as complex: real part [..., 0], imaginary [..., 1], no temporaries
    noise = rng.standard_normal(out.shape + (2,)).view(np.complex128)[..., 0]
    noise *= np.sqrt(noise_power / 2.0)
    out += noise
    return noise_power


def add_receiver_noise(raw: PulseData, amplitude: float, snr_db: float, rng: np.random.Generator) -> PulseData:
    """A copy of noise-free raw echoes with receiver noise added: per-sample SNR ``snr_db`` of a scatterer of
    ``amplitude`` on boresight (the module's definition). Two calls with independent generators on the same
    echoes give two acquisitions of one scene that differ only in their receiver noise."""
    if not isinstance(raw, PulseData) or raw.compressed:
        raise InputDataError("raw", "must be uncompressed PulseData from simulate_echoes")
    if not (np.isfinite(amplitude) and amplitude > 0):
        raise ConfigError("amplitude", f"must be finite and > 0, got {amplitude!r}")
    out = raw.data.astype(np.complex128, copy=True)
    noise_power = _add_noise(out, float(amplitude), snr_db, rng)
    meta = dict(raw.metadata, snr_db=float(snr_db), noise_power=noise_power)
    return replace(raw, data=out.astype(raw.data.dtype, copy=False), metadata=meta)


def simulate_echoes(params, positions, pulse_times, scene: Scene, snr_db: float | None = None,
                    rng: np.random.Generator | None = None, pattern: bool = True,
                    dtype=np.complex128) -> PulseData:
    """Simulate raw (uncompressed) complex-baseband echoes of a scene.

    Parameters
    ----------
    params : :class:`~sarnav.radar.params.RadarParams`.
    positions : (P,3) float64 antenna phase-centre positions, NED [m], one per pulse.
    pulse_times : (P,) strictly increasing slow times [s]; with ``positions`` they give the
        velocity direction (``np.gradient``) that defines the beam (needs P >= 2 when ``pattern``).
    scene : :class:`~sarnav.radar.scene.Scene`.
    snr_db : per-sample SNR of the strongest scatterer on boresight (see module doc); None = no
        noise.
    rng : numpy Generator, required when ``snr_db`` is given.
    pattern : apply the two-way azimuth pattern and the look side (False: isotropic, both sides).
    dtype : np.complex128 (default) or np.complex64 for the returned samples.

    Returns
    -------
    PulseData with ``compressed=False``, ``slant_range = params.slant_range_axis``, the radar's
    wavelength, bandwidth, sample rate, pulse length and windows (``params.pulse_data_fields()``),
    ``metadata`` = {"snr_db", "noise_power", "pattern", "waveform"}.

    Raises
    ------
    InputDataError for malformed arrays; ConfigError (from ``params.validate``) when a target's
    echo does not fit in the receive window at some pulse, or, with ``pattern``, when the PRF is
    below the Doppler bandwidth at the fastest speed of the trajectory.
    """
    pos, t = _check_inputs(positions, pulse_times, scene)
    if dtype not in (np.complex128, np.complex64):
        raise ConfigError("dtype", f"must be numpy.complex128 or numpy.complex64, got {dtype!r}")
    n_p = pos.shape[0]
    if pattern:
        if n_p < 2:
            raise InputDataError("positions", "need P >= 2 pulses to define the beam direction (or pattern=False)")
        along = along_track_directions(pos, t)
        if not np.all(np.isfinite(along)):
            raise InputDataError("positions", "platform does not move between pulses: beam direction undefined")
        look = look_vectors(along, params.look_side)
        speed = float(np.max(np.linalg.norm(np.gradient(pos, t, axis=0), axis=1)))
    else:
        along = np.zeros((n_p, 3))
        look = np.zeros((n_p, 3))
        speed = None
    targets = np.ascontiguousarray(scene.positions)
    amps = np.ascontiguousarray(scene.amplitudes)
    if targets.shape[0]:
        rmin, rmax = _range_extent(pos, targets)
        params.validate(speed=speed, scene_ranges=np.concatenate([rmin, rmax]))
    elif speed is not None:
        params.validate(speed=speed)

    out = np.zeros((n_p, params.n_range_samples), dtype=np.complex128)
    t0 = 2.0 * params.near_range / C
    if targets.shape[0]:
        _echo_kernel(pos, np.ascontiguousarray(along), np.ascontiguousarray(look), targets, amps, t0,
                     params.sample_rate, params.carrier_frequency, params.chirp_rate, params.pulse_length,
                     params.effective_antenna_length, params.wavelength, bool(pattern), out)

    noise_power = 0.0
    if snr_db is not None:
        if targets.shape[0] == 0 or np.max(np.abs(amps)) == 0:
            raise ConfigError("snr_db", "undefined for a scene without a non-zero scatterer")
        noise_power = _add_noise(out, float(np.max(np.abs(amps))), snr_db, rng)

    return PulseData(
        data=out.astype(dtype, copy=False),
        slant_range=params.slant_range_axis,
        pulse_times=t.copy(),
        positions=pos.copy(),
        params=params,
        compressed=False,
        metadata={"snr_db": None if snr_db is None else float(snr_db), "noise_power": noise_power,
                  "pattern": bool(pattern), "waveform": "lfm-centred"},
        **params.pulse_data_fields(),
    )
