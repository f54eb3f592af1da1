"""Size guards of a campaign: what a configuration would allocate, refused with one line naming the key that makes
it large before anything is allocated (the INS's IMU samples, an echo block, the results' histories), and whole
numbers of steps. The scenarios read their keys and call these (``scenarios.vocabulary`` re-exports them)."""

from __future__ import annotations

import math

from sarnav.errors import ConfigError

__all__ = ["MAX_IMU_SAMPLES", "MAX_BLOCK_SAMPLES", "BYTES_PER_BLOCK_SAMPLE", "flight_size_check", "echo_block_check",
           "whole_number", "result_bytes_check"]


#: the longest flight a campaign integrates: IMU samples per run (the INS steps through them one at a time, batched
#: over runs: about 10 us each, so 2e6 samples cost ~20 s per batch) — 100 Hz for 5.5 hours
MAX_IMU_SAMPLES = 2_000_000


def flight_size_check(duration: float, imu_rate: float) -> int:
    """IMU samples of the flight (duration x rate); refused beyond :data:`MAX_IMU_SAMPLES` before anything is
    allocated."""
    n = duration * imu_rate
    if not n <= MAX_IMU_SAMPLES:
        raise ConfigError("trajectory.duration", f"{duration:g} s at imu.rate_hz = {imu_rate:g} Hz is {n:.3g} IMU "
                          f"samples per run; at most {MAX_IMU_SAMPLES:.0e}: shorten the flight or lower the rate")
    return int(n)


#: the largest block of echoes simulated and focused at once, in samples (pulses x range samples): the image chain
#: holds about :data:`BYTES_PER_BLOCK_SAMPLE` bytes per sample at its peak (echoes and range-compressed block in
#: complex128, the image, FFT work arrays; measured: point-target at radar.sample_rate_mhz = 16000, 4.5e6 samples,
#: 570 MB above the interpreter's own and 8 s), so 2^23 samples stay within about 1 GiB and 15 s
MAX_BLOCK_SAMPLES = 2**23
BYTES_PER_BLOCK_SAMPLE = 128


def echo_block_check(n_pulses: float, n_range: int) -> None:
    """Refuse a block of ``n_pulses`` x ``n_range`` samples beyond :data:`MAX_BLOCK_SAMPLES` before anything is
    allocated, naming the key that makes it large: ``radar.sample_rate_mhz`` (range samples) or
    ``trajectory.duration`` (pulses = duration x radar.prf_hz)."""
    n = float(n_pulses) * float(n_range)
    if not n <= MAX_BLOCK_SAMPLES:
        field = "radar.sample_rate_mhz" if n_range >= n_pulses else "trajectory.duration"
        raise ConfigError(field, f"{n_pulses:g} pulses x {n_range} range samples = {n:.3g} samples need about "
                          f"{n * BYTES_PER_BLOCK_SAMPLE / 2**30:.3g} GiB (at most {MAX_BLOCK_SAMPLES:.3g} samples, "
                          f"{MAX_BLOCK_SAMPLES * BYTES_PER_BLOCK_SAMPLE / 2**30:g} GiB): lower radar.sample_rate_mhz, the "
                          "imaged slant-range extent or the block (trajectory.duration x radar.prf_hz)")


def whole_number(field: str, value: float, step: float, what: str) -> int:
    """``value / step`` as an integer, or a ConfigError naming ``field`` (e.g. whole sub-apertures)."""
    n = value / step
    if abs(n - round(n)) > 1e-9 * max(1.0, abs(n)) or round(n) < 1:
        raise ConfigError(field, f"must be a whole number of {what}, got {value}")
    return int(round(n))


def result_bytes_check(runs, duration: float, step: float, n_states: int, limit: int) -> None:
    """Refuse a campaign whose error + sigma histories (float64) would exceed ``limit`` bytes."""
    n_out = math.ceil(duration / step) + 1
    need = (runs if isinstance(runs, int) and runs > 0 else 1) * n_out * n_states * 8 * 2
    if need > limit:
        raise ConfigError("trajectory.duration", f"{duration} s x campaign.runs = {runs} would need "
                          f"{need / 2**30:.1f} GiB of results (limit {limit / 2**30:.0f} GiB): "
                          "shorten the flight or run fewer runs")
