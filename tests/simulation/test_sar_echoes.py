"""``simulation.sar_echoes``: the simulated world as an ``ApertureSource`` of the sub-aperture imager.

Each acquisition is simulated once (a per-run scene: once per aperture and run, shared by the reference and the
flight acquisitions; a shared scene: once for every run), each run has its own receiver noise, and the reference pass
is handed on with its true track."""

from __future__ import annotations

import numpy as np
import pytest

from sarnav.measurements.sar_image import AperturePasses
from sarnav.radar.presets import nav_paper_sim
from sarnav.radar.scene import point_targets
from sarnav.simulation import sar_echoes
from sarnav.trajectory.straight import StraightLevel

RADAR = nav_paper_sim(near_range=1900.0, n_range_samples=1500)  # 1900-2125 m: the target at 2006 m
TRUTH = StraightLevel(start=np.array([0.0, 0.0, -1000.0]), speed=10.0, heading=0.0, duration=3.0)
TARGET = np.array([15.0, 1740.0, 0.0])


def _source(clutter_seeds):
    scene = point_targets(TARGET, 3.16)
    return sar_echoes.SimulatedApertures(RADAR, TRUTH, lambda u, s: AperturePasses(scene, scene), 3.16, -10.0, 7,
                                         [11, 12], clutter_seeds=clutter_seeds)


@pytest.mark.parametrize("per_run", [False, True])
def test_each_acquisition_is_simulated_once(monkeypatch, per_run):
    calls = []
    real = sar_echoes.simulate_echoes
    monkeypatch.setattr(sar_echoes, "simulate_echoes", lambda *a, **k: calls.append(1) or real(*a, **k))
    src = _source([21, 22] if per_run else None)
    for run in range(2):
        src.reference(1, run)
        src.flight(1, run)
    assert len(calls) == (2 if per_run else 1)  # one pass (the reference is the same track and scene)


def test_runs_have_their_own_noise_and_the_reference_its_true_track():
    src = _source(None)
    a, _ = src.flight(1, 0)
    b, _ = src.flight(1, 1)
    assert a.data.shape == b.data.shape and not np.array_equal(a.data, b.data)
    ref = src.reference(1, 0)
    assert ref is src.reference(1, 1)  # a shared scene: one reference acquisition for every run
    np.testing.assert_array_equal(ref.positions, TRUTH.state(ref.times).position)
    np.testing.assert_array_equal(ref.times, RADAR.pulse_times(int(round(RADAR.prf)), 1))
    # the noise level as radar.echoes defines it: amplitude 3.16 at -10 dB per raw sample
    assert (ref.amplitude, ref.snr_db) == (3.16, -10.0) and ref.key is not None
    assert _source([21, 22]).reference(1, 0).key is None  # a per-run scene is not cached by the imager
