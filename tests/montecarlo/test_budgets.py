"""Size guards of a campaign (``sarnav.montecarlo.budgets``): each limit accepts its boundary, refuses just beyond it
with one line naming the key that makes the campaign large, and refuses NaN; the sizes are recomputed here by hand."""

from __future__ import annotations

import math

import pytest

from sarnav.errors import ConfigError
from sarnav.montecarlo.budgets import (
    BYTES_PER_BLOCK_SAMPLE,
    MAX_BLOCK_SAMPLES,
    MAX_IMU_SAMPLES,
    echo_block_check,
    flight_size_check,
    result_bytes_check,
    whole_number,
)


# --------------------------------------------------------------------------- flight_size_check
def test_flight_size_check_returns_the_sample_count_duration_times_rate():
    """The IMU samples of a flight are duration x rate (truncated to an integer)."""
    assert flight_size_check(60.0, 100.0) == 6000
    assert flight_size_check(2.5, 200.0) == 500


def test_flight_size_check_accepts_the_limit_and_refuses_one_sample_beyond():
    """MAX_IMU_SAMPLES itself is allowed; one more sample is a ConfigError naming trajectory.duration and the rate."""
    assert flight_size_check(MAX_IMU_SAMPLES / 100.0, 100.0) == MAX_IMU_SAMPLES
    with pytest.raises(ConfigError) as err:
        flight_size_check((MAX_IMU_SAMPLES + 1) / 100.0, 100.0)
    assert err.value.field == "trajectory.duration"
    assert "imu.rate_hz = 100 Hz" in err.value.message and "\n" not in str(err.value)


@pytest.mark.parametrize("duration, rate", [(float("nan"), 100.0), (10.0, float("nan")), (float("inf"), 1.0)])
def test_flight_size_check_refuses_non_finite_sizes(duration, rate):
    """A NaN or infinite sample count fails ``n <= MAX`` and is refused, never silently accepted."""
    with pytest.raises(ConfigError, match="^trajectory.duration: "):
        flight_size_check(duration, rate)


# --------------------------------------------------------------------------- echo_block_check
def test_echo_block_check_accepts_the_largest_block():
    """A block of exactly MAX_BLOCK_SAMPLES samples passes (both factorisations)."""
    echo_block_check(2**13, 2**10)
    echo_block_check(2**10, 2**13)


@pytest.mark.parametrize("n_pulses, n_range, field", [
    (1000, MAX_BLOCK_SAMPLES // 1000 + 1, "radar.sample_rate_mhz"),  # more range samples than pulses
    (MAX_BLOCK_SAMPLES // 1000 + 1, 1000, "trajectory.duration"),  # more pulses than range samples
])
def test_echo_block_check_names_the_key_that_makes_the_block_large(n_pulses, n_range, field):
    """Beyond the limit the error names the larger factor's key and the memory it would need, in GiB."""
    with pytest.raises(ConfigError) as err:
        echo_block_check(n_pulses, n_range)
    assert err.value.field == field
    n = float(n_pulses) * n_range
    assert f"{n * BYTES_PER_BLOCK_SAMPLE / 2**30:.3g} GiB" in err.value.message


def test_echo_block_check_refuses_nan_pulses():
    """A NaN pulse count (e.g. a NaN duration x PRF) is refused rather than passed on."""
    with pytest.raises(ConfigError):
        echo_block_check(float("nan"), 100)


# --------------------------------------------------------------------------- whole_number
@pytest.mark.parametrize("value, step, want", [(10.0, 0.5, 20), (0.3, 0.1, 3), (7.0, 1.0, 7), (1.0, 1.0, 1)])
def test_whole_number_accepts_multiples_within_rounding(value, step, want):
    """value / step within 1e-9 relative of an integer >= 1 gives that integer (0.3 / 0.1 = 2.9999999999999996)."""
    got = whole_number("trajectory.duration", value, step, "sub-apertures")
    assert got == want and isinstance(got, int)


@pytest.mark.parametrize("value, step", [(1.05, 0.1), (0.0, 1.0), (-2.0, 1.0), (0.4, 1.0)])
def test_whole_number_refuses_fractions_and_counts_below_one(value, step):
    """A fractional count, or fewer than one step, is a ConfigError naming the field and what must be whole."""
    with pytest.raises(ConfigError) as err:
        whole_number("sar.aperture_s", value, step, "IMU samples")
    assert err.value.field == "sar.aperture_s"
    assert err.value.message == f"must be a whole number of IMU samples, got {value}"


# --------------------------------------------------------------------------- result_bytes_check
def _need(runs, duration, step, n_states):
    """Bytes of the error and sigma histories (float64), written out: runs x epochs x states x 8 x 2."""
    return runs * (math.ceil(duration / step) + 1) * n_states * 8 * 2


def test_result_bytes_check_accepts_exactly_the_limit_and_refuses_a_byte_less():
    """The limit is inclusive: need == limit passes, limit = need - 1 is refused naming trajectory.duration."""
    need = _need(50, 10.0, 0.1, 18)
    result_bytes_check(50, 10.0, 0.1, 18, need)
    with pytest.raises(ConfigError) as err:
        result_bytes_check(50, 10.0, 0.1, 18, need - 1)
    assert err.value.field == "trajectory.duration" and "campaign.runs = 50" in err.value.message


@pytest.mark.parametrize("runs", [None, "auto", 0, -3, 2.5])
def test_result_bytes_check_counts_a_run_count_not_yet_known_as_one(runs):
    """A runs value that is not a positive int (not validated yet) is sized as one run."""
    need = _need(1, 100.0, 1.0, 3)
    result_bytes_check(runs, 100.0, 1.0, 3, need)
    with pytest.raises(ConfigError, match="^trajectory.duration: "):
        result_bytes_check(runs, 100.0, 1.0, 3, need - 1)


def test_result_bytes_check_counts_the_initial_epoch_and_a_partial_last_step():
    """Epochs are ceil(duration / step) + 1: 10.05 s at 1 s is 12 epochs, not 11."""
    need = 1 * 12 * 1 * 16
    result_bytes_check(1, 10.05, 1.0, 1, need)
    with pytest.raises(ConfigError):
        result_bytes_check(1, 10.05, 1.0, 1, need - 1)
