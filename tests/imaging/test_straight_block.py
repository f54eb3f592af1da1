"""Focusing a straight-track block (sarnav.imaging.straight_block): the point target lands where its geometry says,
with the theoretical resolution, for RDA and BPA; a speed error defocuses and autofocus recovers the speed."""

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.imaging.straight_block import focus_straight_block
from sarnav.signal.metrics import point_target_metrics
from sarnav.units import C


@pytest.mark.parametrize("algorithm", ["rda", "bpa"])
def test_point_target_is_at_its_zero_doppler_coordinates_with_theoretical_irw(point_target_block, algorithm):
    b = point_target_block
    centre = np.array([0.0, 0.0, -b.altitude])
    img, af = focus_straight_block(b.rc, b.speed, centre, algorithm=algorithm, bpa_interpolation="upsample")
    assert af is None
    m = point_target_metrics(img, near=(0.0, b.r0), half_width=32)
    assert abs(m["peak_position"][0]) < 0.05 * img.dy + 1e-3 and abs(m["peak_position"][1] - b.r0) < 0.05 * img.dx
    lam = C / b.rc.params.carrier_frequency
    aperture = b.speed * b.rc.n_pulses / b.rc.params.prf
    assert m["y"]["irw_m"] == pytest.approx(0.886 * lam * b.r0 / (2 * aperture), rel=0.03)
    assert m["x"]["irw_m"] == pytest.approx(0.886 * C / (2 * b.rc.params.bandwidth), rel=0.03)


def test_mapdrift_recovers_the_speed_and_bpa_refuses_autofocus(point_target_block):
    b = point_target_block
    centre = np.array([0.0, 0.0, -b.altitude])
    _, af = focus_straight_block(b.rc, b.speed + 1.0, centre, autofocus="mapdrift")
    assert af["speed_estimate"] == pytest.approx(b.speed, abs=0.1)
    with pytest.raises(ConfigError, match="^image.autofocus"):
        focus_straight_block(b.rc, b.speed, centre, algorithm="bpa", autofocus="mapdrift")
    with pytest.raises(ConfigError, match="^image.algorithm"):
        focus_straight_block(b.rc, b.speed, centre, algorithm="omega-k")
