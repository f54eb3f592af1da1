"""The base of the error-state kinds (``sarnav.scenarios.error_state.ErrorStateKind``) on a toy subclass: names and
units from its layout, the radar check of validation, and ``simulate``'s guards (seeds, empty batch, a covariance
that lost positive definiteness reported as one line naming ``initial``, never NaN in the results)."""

from __future__ import annotations

import warnings
from types import SimpleNamespace
from typing import ClassVar

import numpy as np
import pytest
from numpy.linalg import LinAlgError

from sarnav.errors import ConfigError
from sarnav.filters import ErrorStateLayout
from sarnav.montecarlo.record import RunRecord
from sarnav.radar.presets import nav_paper_sim
from sarnav.scenarios.error_state import ErrorStateKind

LAYOUT = ErrorStateLayout(("b_alt",), scalar_units=("m",))


def _record(run, sigma=1.0, residual=0.5, residual_sigma=1.0, nees=2.0):
    """A record of 3 epochs and 2 updates with every value finite unless overridden (a scalar or a full array)."""
    n = LAYOUT.n
    t = np.array([0.0, 1.0, 2.0])
    full = lambda v, shape: np.broadcast_to(np.asarray(v, dtype=float), shape).copy()
    return RunRecord(run=run, time=t, error=np.zeros((3, n)), sigma=full(sigma, (3, n)), nees=full(nees, (3,)),
                     update_time=t[1:], residual=full(residual, (2, 1)), residual_sigma=full(residual_sigma, (2, 1)),
                     nis=np.ones(2), nis_dof=np.ones(2, dtype=np.int64))


class Toy(ErrorStateKind):
    """An error-state kind whose parameters and records are given to it; counts the calls to ``simulate_runs``."""

    kind = "toy-error-state"
    layout = LAYOUT
    measurement_names = ("alt",)
    measurement_units = ("m",)
    extra: ClassVar[dict] = {"toc": {"units": "s", "description": "time of closest approach"}}

    def __init__(self, prm=None, make=None):
        self.prm = SimpleNamespace() if prm is None else prm
        self.make = make or (lambda prm, run_ids, seeds: [_record(r) for r in run_ids])
        self.calls = []

    def parse(self, cfg):
        return self.prm

    def simulate_runs(self, prm, run_ids, seeds):
        self.calls.append(list(run_ids))
        return self.make(prm, run_ids, seeds)


def test_names_and_units_come_from_the_layout_and_the_class():
    """State names/units are the layout's (18 + 1 here); measurement names/units are fresh lists of the class's."""
    k = Toy()
    assert k.state_names({}) == LAYOUT.state_names() and len(k.state_names({})) == LAYOUT.n
    assert k.state_units({}) == LAYOUT.state_units()
    names = k.meas_names({})
    assert names == ["alt"] and k.meas_units({}) == ["m"]
    names.append("x")  # a caller's list, not the class attribute
    assert Toy.measurement_names == ("alt",)
    assert k.extra_attrs({}) is Toy.extra


def test_simulate_returns_the_records_of_the_runs():
    """Finite records pass unchanged, in order; the kind's function sees the run ids and seeds it was given."""
    seeds = np.random.SeedSequence(1).spawn(3)
    seen = {}

    def make(prm, run_ids, s):
        seen["seeds"] = list(s)
        return [_record(r) for r in run_ids]

    k = Toy(make=make)
    recs = k.simulate({}, [4, 5, 6], seeds)
    assert [r.run for r in recs] == [4, 5, 6] and seen["seeds"] == seeds and k.calls == [[4, 5, 6]]


def test_simulate_refuses_a_seed_count_that_is_not_one_per_run():
    """run_ids and seeds must match one to one: the ``seeds`` ConfigError, before any simulation."""
    k = Toy()
    with pytest.raises(ConfigError, match=r"^seeds: need one seed per run, got 1 for 2 runs$"):
        k.simulate({}, [0, 1], np.random.SeedSequence(0).spawn(1))
    assert k.calls == []


def test_an_empty_batch_simulates_nothing():
    """No runs: an empty list without parsing or simulating."""
    class NoParse(Toy):
        def parse(self, cfg):
            raise AssertionError("parsed an empty batch")

    k = NoParse()
    assert k.simulate({}, [], []) == [] and k.calls == []


def test_a_singular_matrix_in_the_filter_is_one_line_naming_initial():
    """A LinAlgError raised while simulating becomes ConfigError('initial', ...) with numpy's words in brackets."""
    def make(prm, run_ids, seeds):
        raise LinAlgError("Singular matrix")

    with pytest.raises(ConfigError) as err:
        Toy(make=make).simulate({}, [0], [np.random.SeedSequence(0)])
    assert err.value.field == "initial"
    assert "not positive definite (Singular matrix)" in err.value.message and "\n" not in str(err.value)
    assert err.value.__cause__ is None and err.value.__suppress_context__


@pytest.mark.parametrize("bad, where", [
    ({"sigma": np.array([[1.0] * LAYOUT.n, [1.0] * LAYOUT.n, [np.nan] + [1.0] * (LAYOUT.n - 1)])},
     "at t = 2 s of run 7"),
    ({"nees": np.array([1.0, np.inf, 1.0])}, "at t = 1 s of run 7"),
    ({"residual_sigma": np.array([[1.0], [np.nan]])}, "at the update at t = 2 s of run 7"),
])
def test_a_record_with_nan_sigma_nees_or_residual_sigma_is_never_returned(bad, where):
    """NaN sigma / NEES at an epoch, or a residual without its sigma: ConfigError naming initial, the time and run."""
    k = Toy(make=lambda prm, run_ids, seeds: [_record(r, **bad) for r in run_ids])
    with pytest.raises(ConfigError) as err:
        k.simulate({}, [7], [np.random.SeedSequence(0)])
    assert err.value.field == "initial" and where in err.value.message


def test_an_absent_measurement_with_nan_sigma_is_fine():
    """NaN residual with NaN sigma is a measurement that was not there, not a broken covariance."""
    k = Toy(make=lambda prm, run_ids, seeds: [_record(r, residual=np.nan, residual_sigma=np.nan) for r in run_ids])
    assert len(k.simulate({}, [0], [np.random.SeedSequence(0)])) == 1


def test_invalid_value_warnings_inside_the_simulation_are_silenced_and_the_nan_reported():
    """numpy's 'invalid value' warning while simulating is suppressed; the NaN it makes is the one-line error."""
    def make(prm, run_ids, seeds):
        return [_record(r, sigma=np.sqrt(np.full((3, LAYOUT.n), -1.0))) for r in run_ids]

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ConfigError, match="^initial: .*at t = 0 s of run 0"):
            Toy(make=make).simulate({}, [0], [np.random.SeedSequence(0)])


def _radar_prm(prf, speed=60.0, **flags):
    radar = nav_paper_sim(prf=prf, antenna_length=0.5)
    return SimpleNamespace(radar=radar, trajectory=SimpleNamespace(speed=speed), **flags), radar


def test_validation_refuses_a_prf_below_the_doppler_band_naming_radar_prf_hz():
    """Images at a speed whose Doppler band exceeds the PRF: ConfigError named radar.prf_hz (validate and simulate)."""
    prm, radar = _radar_prm(prf=100.0)
    band = 4 * 60.0 / radar.wavelength * np.sin(radar.beamwidth / 2)  # (4V/lambda) sin(beamwidth/2), no squint
    assert band > 100.0
    k = Toy(prm)
    with pytest.raises(ConfigError) as err:
        k.validate({})
    assert err.value.field == "radar.prf_hz"
    with pytest.raises(ConfigError, match="^radar.prf_hz: "):
        k.simulate({}, [0], [np.random.SeedSequence(0)])
    assert k.calls == []
    Toy(_radar_prm(prf=1.01 * band)[0]).validate({})  # just above the band: accepted


@pytest.mark.parametrize("flags", [{"sar_enabled": False}, {"measurement": "oracle"}, {"radar": None}])
def test_validation_skips_the_radar_check_when_no_image_is_formed(flags):
    """No SAR, oracle measurements, or no radar at all: the PRF is not checked."""
    prm, _ = _radar_prm(prf=1.0)
    for key, value in flags.items():
        setattr(prm, key, value)
    Toy(prm).validate({})
