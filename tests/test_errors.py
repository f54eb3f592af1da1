"""sarnav.errors: the one-line format the CLI prints, picklable errors, range checks that name the field."""

import math
import pickle
import signal

import numpy as np
import pytest

from sarnav.errors import (ConfigError, InputDataError, Interrupted, SarnavError, deferred_signals, raise_interrupted,
                           require_finite, require_positive)


def test_config_error_is_field_colon_message_on_one_line():
    err = ConfigError("imu.tau_accel", "must be > 0 s, got -1.0")
    assert str(err) == "imu.tau_accel: must be > 0 s, got -1.0"
    assert err.field == "imu.tau_accel" and err.message == "must be > 0 s, got -1.0"
    assert isinstance(err, SarnavError) and isinstance(err, ValueError)
    assert str(InputDataError("rc", "empty")) == "rc: empty"


def test_errors_pickle_with_field_and_message():  # they cross process boundaries (workers)
    for err in (ConfigError("a.b", "m"), InputDataError("x", "y"), Interrupted(15)):
        back = pickle.loads(pickle.dumps(err))
        assert type(back) is type(err) and str(back) == str(err)
    assert pickle.loads(pickle.dumps(Interrupted(2))).signum == 2


@pytest.mark.parametrize("value, ok", [(1.5, 1.5), (3, 3.0), (np.float32(2.0), 2.0)])
def test_require_positive_accepts_finite_positive_numbers(value, ok):
    assert require_positive("k", value) == ok


@pytest.mark.parametrize("value, text", [(0.0, "must be finite and > 0 m"), (-1, "must be finite and > 0 m"),
                                         (math.inf, "must be finite and > 0 m"), (math.nan, "must be finite"),
                                         (True, "must be a number > 0 m"), ("3", "must be a number > 0 m"),
                                         (None, "must be a number > 0 m")])
def test_require_positive_names_the_field_and_the_range(value, text):
    with pytest.raises(ConfigError) as err:
        require_positive("trajectory.speed", value, "m")
    assert err.value.field == "trajectory.speed" and err.value.message.startswith(text)


def test_require_finite_prints_its_range_with_the_unit():
    assert require_finite("h", 5, 0.5, 60.0, "s") == 5.0
    with pytest.raises(ConfigError, match=r"^h: must be in \[0.5, 60\] s, got 61.0$"):
        require_finite("h", 61.0, 0.5, 60.0, "s")
    with pytest.raises(ConfigError, match=r"^h: must be finite in \[-inf, 10\], got nan$"):
        require_finite("h", math.nan, hi=10.0)
    with pytest.raises(ConfigError, match=r"^h: must be a number, got False$"):
        require_finite("h", False)


def test_interrupted_is_128_plus_n_material_and_handlers_raise_it():
    assert isinstance(Interrupted(15), KeyboardInterrupt) and str(Interrupted(15)) == "interrupted by signal 15"
    with pytest.raises(Interrupted) as err:
        raise_interrupted(signal.SIGTERM, None)
    assert err.value.signum == signal.SIGTERM


def test_deferred_signals_raise_after_the_block_only_under_the_commands_handler():
    saved = signal.signal(signal.SIGUSR1, signal.SIG_DFL)
    old = signal.signal(signal.SIGTERM, raise_interrupted)
    try:
        with pytest.raises(Interrupted) as err:
            with deferred_signals():
                signal.raise_signal(signal.SIGTERM)  # recorded, not raised inside the block
                reached = True
        assert reached and err.value.signum == signal.SIGTERM
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # not the command's handler: left alone, a no-op
        with deferred_signals() as d:
            signal.raise_signal(signal.SIGTERM)
        assert d.pending == []
    finally:
        signal.signal(signal.SIGTERM, old)
        signal.signal(signal.SIGUSR1, saved)
