"""Open-loop spacecraft campaign (simulation.spacecraft): short runs only (the 100-run campaigns are in
tests/simulation/test_spacecraft_campaign.py, marked slow)."""

import math

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.simulation.spacecraft import OpenLoopParams, orbit_frame_dcm, radial_intrack_crosstrack, run_open_loop
from helpers import spawn_seeds


@pytest.fixture(scope="module")
def short():
    p = OpenLoopParams.tc1(duration=50.0, truth_misalignment_psd=3.4e-13)
    return p, run_open_loop(p, spawn_seeds(4, 9))


def test_update_count_g11():
    assert OpenLoopParams.tc2().update_steps().size == 73  # t = 8.2 k <= 600 s
    assert OpenLoopParams.tc2().update_steps()[-1] * 0.01 == pytest.approx(598.6)
    assert OpenLoopParams.tc2(n_updates=72).update_steps().size == 72  # the paper's count


def test_shapes_and_records(short):
    p, res = short
    U = 6  # 8.2 .. 49.2 s
    assert res.update_time.shape == (U,) and res.residual.shape == (4, U, 4) and res.nis.shape == (4, U)
    assert res.error.shape == res.sigma.shape == (4, res.time.size, 9)
    assert np.all(np.diff(res.time) > 0) and res.time[0] == 0 and res.time[-1] == pytest.approx(50.0)
    assert set(np.round(res.update_time, 6)) <= set(np.round(res.time, 6))
    assert np.allclose(res.sigma[:, 0], p.sigma0)  # t = 0: the initial P
    assert np.all(res.beta == 0.2)  # TC-1: underweighted (first 10 updates)
    # the updates shrink the position sigma from 1000 m
    assert np.all(res.sigma[:, -1, :3] < 1000.0) and np.all(np.isfinite(res.nees))


def test_runs_do_not_depend_on_batching(short):
    p, res = short
    alone = run_open_loop(p, spawn_seeds(4, 9)[2:3])
    for name in ("error", "sigma", "nees", "residual", "nis", "residual_sigma"):
        assert np.array_equal(getattr(alone, name)[0], getattr(res, name)[2]), name


def test_radial_intrack_crosstrack_helper(short):
    _, res = short
    err, sig = radial_intrack_crosstrack(res)
    C = orbit_frame_dcm(res.truth_r, res.truth_v)
    assert np.allclose(C @ np.swapaxes(C, -1, -2), np.eye(3), atol=1e-12)
    assert np.allclose(C[:, 0], res.truth_r / np.linalg.norm(res.truth_r, axis=1, keepdims=True))
    assert np.allclose(np.linalg.norm(err[..., :3], axis=-1), np.linalg.norm(res.error[..., :3], axis=-1))
    k = 7
    cov = C[k] @ res.cov_blocks[1, k, 0] @ C[k].T
    assert np.allclose(sig[1, k, :3], np.sqrt(np.diag(cov)))
    # the weak direction is in-track after a few updates (sigma_mu x slant range)
    assert np.all(sig[:, -1, 1] > sig[:, -1, 0]) and np.all(sig[:, -1, 1] > sig[:, -1, 2])


@pytest.mark.parametrize("changes,field", [({"sigma_r0": 0.0}, "initial.sigma_r0"),
                                           ({"update_interval": 8.205}, "simulation.update_interval"),
                                           ({"look_angle": math.radians(95)}, "antenna.look_angle"),
                                           ({"truth_misalignment_psd": -1.0}, "truth.misalignment_psd")])
def test_bad_parameters(changes, field):
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        OpenLoopParams.tc2(**changes)


def test_look_angle_beyond_the_limb_is_a_one_line_error():
    with pytest.raises(ConfigError, match="antenna.look_angle"):
        run_open_loop(OpenLoopParams.tc2(duration=10.0, look_angle=math.radians(75.0)), spawn_seeds(1, 9))


def _rz(a):
    return np.array([[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])


@pytest.mark.parametrize("name, paper_x", [("spacecraft-tc1", 20.0), ("spacecraft-tc2", 12.0)])
def test_no_initial_longitude_gives_the_papers_x_sigma(name, paper_x):
    """Issue 29 (Pogorelsky et al., TC-1 x 36.9 m against the paper's 20 m): the paper does not state the orbit's
    longitude, so the final ECEF x 1-sigma could be a projection. The dynamics are symmetric about the Earth's axis, so
    a node shifted by a rotates the final position covariance, P' = Rz(a) P Rz(a)^T (checked by simulating a 90-deg
    shift: within 2 %, the terrain under the track differs). Over every longitude the x 1-sigma stays above 24 m
    (TC-1) and 19 m (TC-2): the paper's 20 and 12 m are not a choice of longitude."""
    import dataclasses

    from sarnav.scenarios import spacecraft as sc
    from sarnav.scenarios.registry import packaged

    prm = sc.parse(packaged(name))
    prm = prm[0] if isinstance(prm, tuple) else prm
    P = run_open_loop(prm, np.random.SeedSequence(1).spawn(1)).cov_blocks[0, -1, 0]
    shifted = dataclasses.replace(prm, elements=dataclasses.replace(prm.elements, raan=prm.elements.raan + 0.5 * math.pi))
    P90 = run_open_loop(shifted, np.random.SeedSequence(1).spawn(1)).cov_blocks[0, -1, 0]
    np.testing.assert_allclose(np.sqrt(np.diag(P90)), np.sqrt(np.diag(_rz(0.5 * math.pi) @ P @ _rz(0.5 * math.pi).T)),
                               rtol=0.02)
    x_sigma = [math.sqrt((_rz(a) @ P @ _rz(a).T)[0, 0]) for a in np.radians(np.arange(0.0, 360.0, 0.25))]
    assert min(x_sigma) > paper_x + 4.0


def test_t20_a_smaller_initial_misalignment_converges_faster_to_a_lower_floor():
    """Pogorelsky et al. T20 (issue 29): 0.01 deg against 0.1 deg initial misalignment, both without underweighting
    (TC-2 with only sigma_mu0 changed; the paper's TC-1 also underweights), 600 s. Predicted position and velocity
    1-sigma (norm of the three axes): with 0.01 deg every level is reached sooner (at 100 s 200 m against 851 m, 0.21
    against 0.88 m/s; the 0.1-deg filter's final 729 m and 0.79 m/s are reached at 8.2 s and 24.6 s) and the floor is
    ~5x lower (153 m, 0.166 m/s); relative to its own floor the 0.1-deg filter settles sooner (within 1.25x of its
    final sigma at 57 s against 180 s, velocity 41 s against 98 s): it stops improving at the in-track error the
    misalignment leaves (docs/spacecraft.md)."""
    fast = run_open_loop(OpenLoopParams.tc2(), spawn_seeds(1, 20))  # the paper's 600 s
    slow = run_open_loop(OpenLoopParams.tc2(sigma_mu0=math.radians(0.1)), spawn_seeds(1, 20))
    t = fast.time
    np.testing.assert_array_equal(t, slow.time)
    k100 = int(np.searchsorted(t, 100.0))
    for block in (slice(0, 3), slice(3, 6)):
        a = np.linalg.norm(fast.sigma[0, :, block], axis=1)
        b = np.linalg.norm(slow.sigma[0, :, block], axis=1)
        assert np.all(a[1:] <= b[1:] * (1 + 1e-9))                      # never above, after the start
        assert a[k100] < 0.4 * b[k100] and a[-1] < 0.4 * b[-1]          # and far below from 100 s on
        below = lambda s, level: t[int(np.argmax(s <= level))]  # noqa: E731 - first time at or under a level
        assert below(b, 1.25 * b[-1]) < below(a, 1.25 * a[-1])          # but 0.1 deg settles sooner, higher
