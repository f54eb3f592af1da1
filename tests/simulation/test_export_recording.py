"""``sarnav export``: the recording of run K holds what the campaign's run K was made of.

The inputs are rebuilt here independently of the exporter, from the run's seed and the documented order of its
random draws (``simulation.flight``: IMU biases, measurement biases and initial error, the bias drive, the clutter
seed, IMU sample 0; per update the IMU block, the altimeter noise, the SAR noises) with the sensor models
themselves (``sensors.imu``, ``sensors.gauss_markov``) and the world's echoes (``simulation.sar_echoes``): the IMU
samples bit for bit, the altimeter values, the CPHD pulses within -100 dB of the simulated acquisitions, the
reference points, the initial estimate; and the image extractor on the recording measures what it measures on the
simulated world.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sarnav.cli.main import main
from sarnav.montecarlo.seeding import run_seeds
from sarnav.recording import read_recording
from sarnav.rotations import corrupt_attitude
from sarnav.scenarios import rda_nav as rn
from sarnav.scenarios.config import load_scenario
from sarnav.sensors.gauss_markov import fogm_coefficients, fogm_path
from sarnav.sensors.imu import ImuBlocks, ImuModel
from sarnav.simulation import rda_nav, rda_nav_world as world
from sarnav.simulation.export import export_rda_nav
from sarnav.simulation.sar_echoes import SimulatedApertures, simulated_imager
from sarnav.tomlio import dump_toml

RUNS, RUN = 3, 1
CASES = {
    "rda-nav": ("rda-nav", ["scene.geolocation_sigma_m=[0.3, 0.3, 0.5]"]),  # a map with errors
    "terrain": ("rda-nav-terrain", []),
    "turning-bpa": ("rda-nav", ["sar.algorithm=bpa", "trajectory.type=turning"]),
    "flexsar": ("rda-nav-flexsar", []),
}


class Case:
    """Run RUN of a 2-s campaign of ``name`` exported to ``folder``, and its inputs drawn again here."""

    def __init__(self, name, sets, folder):
        cfg = load_scenario(name, ["trajectory.duration=2.0", *sets], runs=RUNS)
        self.prm = prm = rn.parse(cfg)
        self.seed = run_seeds(cfg["campaign"]["seed"], RUNS)[RUN]
        self.export = export_rda_nav(prm, folder, self.seed, run=RUN, runs=RUNS, campaign_seed=cfg["campaign"]["seed"],
                                     scenario_name=name, scenario_text=dump_toml(cfg))
        self.rec = read_recording(folder)
        self._draw()

    def _draw(self):
        """The run's draws in the documented order (module docstring)."""
        prm = self.prm
        rng = np.random.default_rng(self.seed)
        imu = ImuModel(prm.imu.grade, prm.imu_rate, prm.imu.tau_accel, prm.imu.tau_gyro)
        ba, bg = imu.initial_biases([rng])
        w0 = rng.standard_normal(3 + 18)
        n, m, c = prm.n_updates, prm.samples_per_update, prm.samples_per_step
        drive = rng.standard_normal((n * m // c, 3))
        self.clutter_seed = int(rng.integers(2**63))
        self.t_imu = np.arange(n * m + 1) * (1.0 / prm.imu_rate)
        blocks = ImuBlocks(imu, prm.trajectory.specific_force(self.t_imu, None),
                           prm.trajectory.angular_rate(self.t_imu, None), ba, bg, [rng])
        self.nu, self.om = [blocks.first[0][0]], [blocks.first[1][0]]
        self.alt_noise = []
        for _ in range(n):
            nu, om, _, _ = blocks.next(m)
            self.nu.append(nu[0, 1:])
            self.om.append(om[0, 1:])
            self.alt_noise.append(rng.standard_normal())
            rng.standard_normal(2 * prm.targets_per_image)
        self.nu, self.om = np.concatenate(self.nu), np.concatenate(self.om)
        bm0 = prm.bias_sigma * w0[:3]
        path, last = fogm_path(bm0[None], drive[None], *fogm_coefficients(prm.bias_sigma, prm.bias_tau, c / prm.imu_rate))
        self.bm = np.concatenate([path[0], last])  # at the output epochs (every c samples)
        self.dx0 = prm.p0_sigma * w0[3:]
        self.ba0, self.bg0 = blocks.first[2][0, 0], blocks.first[3][0, 0]

    def simulated(self):
        """The simulated world's apertures of this run (``simulation.sar_echoes``)."""
        prm, cs = self.prm, self.clutter_seed
        targets = world.reference_targets(prm)
        return SimulatedApertures(prm.radar, prm.trajectory, world.scene_factory(prm, targets),
                                  prm.scene["reflector_amplitude"], prm.snr_db, prm.scene["seed"], [cs],
                                  [cs] if prm.scene["clutter_per_run"] else None, world.reference_track(prm))


@pytest.fixture(scope="module", params=["rda-nav", "terrain", "turning-bpa",
                                        pytest.param("flexsar", marks=pytest.mark.slow)])
def case(request, tmp_path_factory):
    name, sets = CASES[request.param]
    return Case(name, sets, tmp_path_factory.mktemp(request.param) / "rec")


def test_imu_samples_are_the_truth_imus_bit_for_bit(case):
    imu = case.rec.imu
    assert imu.kind == "rates" and case.rec.manifest.imu.rate_hz == case.prm.imu_rate
    np.testing.assert_array_equal(imu.time, case.t_imu)
    np.testing.assert_array_equal(imu.accel, case.nu)
    np.testing.assert_array_equal(imu.gyro, case.om)
    assert case.rec.manifest.imu.spec == case.prm.imu or case.rec.manifest.imu.spec.grade.name == "custom"
    g, h = case.rec.manifest.imu.spec.grade, case.prm.imu.grade
    np.testing.assert_allclose([g.vrw, g.accel_bias, g.arw, g.gyro_bias], [h.vrw, h.accel_bias, h.arw, h.gyro_bias],
                               rtol=1e-14)


def test_altimeter_is_the_measurement_the_navigator_fused(case):
    prm, alt = case.prm, case.rec.altimeter
    steps = prm.samples_per_update // prm.samples_per_step
    t = np.arange(1, prm.n_updates + 1, dtype=float)
    np.testing.assert_allclose(alt.time, t, rtol=0, atol=1e-12)
    j = np.arange(1, prm.n_updates + 1) * steps
    expected = (-prm.trajectory.state(t).position[:, 2] + case.bm[j, 0] + prm.alt_sigma * np.array(case.alt_noise))
    np.testing.assert_allclose(alt.altitude, expected, rtol=0, atol=1e-9)
    m = case.rec.manifest.altimeter
    assert (m.sigma, m.bias_sigma, m.tau) == pytest.approx((prm.alt_sigma, prm.bias_sigma[0], prm.bias_tau[0]),
                                                           rel=1e-14)
    # the truth log: biases at the output epochs, the measurement biases' FOGM path
    tr = case.rec.truth
    np.testing.assert_allclose(np.c_[tr.extra["b_alt"], tr.extra["b_range"], tr.extra["b_cross"]], case.bm,
                               rtol=0, atol=1e-15)
    np.testing.assert_allclose(tr.position, prm.trajectory.state(tr.time).position, rtol=0, atol=1e-9)


def test_sar_offsets_are_the_truth_biases_added_to_the_images(case):
    prm = case.prm
    steps = prm.samples_per_update // prm.samples_per_step
    j = np.arange(1, prm.n_updates + 1) * steps
    expected = np.repeat(case.bm[j, None, 1:], prm.targets_per_image, axis=1)  # image_added_noise is off
    np.testing.assert_allclose(case.rec.sar_offsets, expected, rtol=0, atol=1e-15)


def test_cphd_pulses_are_the_simulated_acquisitions(case):
    sim, src = case.simulated(), case.rec.source()
    ref_track = world.reference_track(case.prm)
    for u in range(case.prm.n_updates):
        rc_sim, _ = sim.flight(u, 0)
        ref_sim = sim.reference(u, 0)
        rc, _ = src.flight(u, 0)
        ref = src.reference(u, 0)
        for got, want in ((rc, rc_sim), (ref.pulses, ref_sim.pulses)):
            err = np.linalg.norm(got.data - want.data) / np.linalg.norm(want.data)
            assert 20 * np.log10(err) < -100, 20 * np.log10(err)
            np.testing.assert_allclose(got.pulse_times, want.pulse_times, rtol=0, atol=1e-12)
            np.testing.assert_array_equal(got.slant_range, want.slant_range)
        np.testing.assert_allclose(ref.positions, ref_track.state(ref.times).position, rtol=0, atol=1e-6)
        np.testing.assert_allclose(ref.velocities, ref_track.state(ref.times).velocity, rtol=0, atol=1e-5)
        np.testing.assert_allclose(rc.positions, case.prm.trajectory.state(rc.pulse_times).position, atol=1e-6)
        assert ref.amplitude**2 / 10 ** (ref.snr_db / 10) == pytest.approx(
            ref_sim.amplitude**2 / 10 ** (ref_sim.snr_db / 10), rel=1e-14)


def test_reference_points_and_initial_estimate(case):
    prm = case.prm
    targets = world.reference_targets(prm)
    pts = case.rec.points
    np.testing.assert_array_equal(pts.anchors, targets)
    np.testing.assert_array_equal(pts.map, targets + world.map_errors(prm, [case.clutter_seed])[0])
    np.testing.assert_array_equal(pts.map_sigma, np.broadcast_to(prm.scene["geolocation_sigma"], targets.shape))
    assert case.rec.noise_model_seed == prm.scene["seed"]
    ini, dx = case.rec.manifest.initial, case.dx0
    st = prm.trajectory.state(np.array([0.0]))
    np.testing.assert_array_equal(ini.p, st.position[0] - dx[0:3])
    np.testing.assert_array_equal(ini.v, st.velocity[0] - dx[3:6])
    np.testing.assert_array_equal(ini.q, corrupt_attitude(st.quaternion, dx[None, 6:9])[0])
    np.testing.assert_array_equal(ini.ba, case.ba0 - dx[9:12])
    np.testing.assert_array_equal(ini.bg, case.bg0 - dx[12:15])
    np.testing.assert_array_equal(ini.bm, case.bm[0] - dx[15:18])
    sig = np.concatenate([ini.sigma[k] for k in ("p", "v", "th", "ba", "bg")])
    np.testing.assert_allclose(sig, prm.p0_sigma[:15], rtol=1e-14)


def test_the_extractor_measures_on_the_recording_what_it_measures_on_the_world(case):
    """Same estimated track, same settings: the image-derived TOC and range agree to far below a millimetre."""
    prm, rec = case.prm, case.rec
    targets = world.reference_targets(prm)
    cs = case.clutter_seed
    sim = simulated_imager(prm.radar, prm.trajectory, targets, world.scene_factory(prm, targets),
                           prm.scene["reflector_amplitude"], prm.snr_db, prm.scene["seed"], [cs],
                           [cs] if prm.scene["clutter_per_run"] else None, world.reference_track(prm), prm.imaging)
    im = rec.imager(prm.imaging)
    u = prm.n_updates - 1
    ap_t = u + np.linspace(0.0, 1.0, 11)
    st = prm.trajectory.state(ap_t)
    p, v = st.position[None] + [0.3, -0.5, 0.2], st.velocity[None] + [0.02, -0.01, 0.0]
    kw = dict(speed_sigma=np.array([0.05]), map_targets=rec.points.map[u][None], along_sigma=np.array([0.5]),
              ap_q=st.quaternion[None])
    a, b = sim.measure(u, ap_t, p, v, **kw), im.measure(u, ap_t, p, v, **kw)
    np.testing.assert_array_equal(a.status, b.status)
    assert np.all(a.status == 0)
    np.testing.assert_allclose(b.range, a.range, rtol=0, atol=1e-6)
    np.testing.assert_allclose(b.toc * prm.trajectory.speed, a.toc * prm.trajectory.speed, rtol=0, atol=1e-5)
    np.testing.assert_allclose(b.sigma, a.sigma, rtol=1e-5)
    np.testing.assert_allclose(b.sensitivity, a.sensitivity, rtol=1e-5, atol=1e-9)


def test_the_observer_changes_no_number(case):
    """The exported run's record is the campaign's run (flown without the observer), bit for bit, as the recording's
    reference allows: a 'cphd-pass' reference carries no DEM, so over terrain the campaign compared is the one without
    ``ImagingSettings.terrain_correction`` (docs/recording.md §6)."""
    if case.prm.radar.prf > 200:
        pytest.skip("the FlexSAR run is checked by the others")
    prm = replace(case.prm, imaging=replace(case.prm.imaging, terrain_correction=False))
    plain = rda_nav.run(prm, [case.seed], [RUN])[0]
    got = case.export.record
    assert got.run == RUN
    for name in ("error", "sigma", "nees", "residual", "nis"):
        np.testing.assert_array_equal(getattr(got, name), getattr(plain, name))


def test_export_command(tmp_path, capsys):
    out = tmp_path / "rec"
    assert main(["export", "rda-nav", "--set", "trajectory.duration=1.0", "--runs", "2", "--run", "1",
                 "--out", str(out)]) == 0
    assert "rda-nav: run 1 of seed 2022 ->" in capsys.readouterr().out
    rec = read_recording(out)
    assert rec.manifest.simulation.run == 1 and rec.manifest.simulation.runs == 2
    assert len(rec.manifest.apertures) == 1 and "trajectory" in rec.scenario_text
    assert main(["export", "rda-nav", "--set", "trajectory.duration=1.0", "--runs", "2", "--run", "0",
                 "--out", str(out), "--overwrite", "--quiet"]) == 0
    assert read_recording(out).manifest.simulation.run == 0


def test_an_interrupted_export_never_reads_as_a_recording(tmp_path, monkeypatch):
    """The manifest is written last (through a rename): an export stopped before it leaves no flight.toml."""
    from sarnav.simulation import export

    real = export.write_columns

    def fail_on_truth(path, columns):
        if path.name == "truth.csv":
            raise KeyboardInterrupt
        return real(path, columns)

    monkeypatch.setattr(export, "write_columns", fail_on_truth)
    out = tmp_path / "rec"
    code = main(["export", "rda-nav", "--set", "trajectory.duration=1.0", "--run", "0", "--out", str(out)])
    assert code != 0  # the CLI turns the interrupt into its one line and exit status
    assert (out / "imu.csv").exists() and not (out / "flight.toml").exists()
    with pytest.raises(Exception, match="flight.toml"):
        read_recording(out)


@pytest.mark.parametrize("args, message", [
    (["--run", "2", "--runs", "2"], "--run: must be a run of the campaign, 0 to 1"),
    (["--run", "0", "--set", "sar.measurement=oracle"], "sar.measurement: a recording holds the radar's pulses"),
    (["--run", "0", "--out-exists"], "--out: "),
])
def test_export_command_errors(tmp_path, capsys, args, message):
    out = tmp_path / "rec"
    if "--out-exists" in args:
        args = [a for a in args if a != "--out-exists"]
        out.mkdir()
        (out / "notes.txt").write_text("mine")
    assert main(["export", "rda-nav", "--set", "trajectory.duration=1.0", *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"sarnav: error: {message}") and "\n" not in err, err
    assert not out.exists() or [p.name for p in out.iterdir()] == ["notes.txt"]  # nothing written


def test_export_refuses_other_kinds(tmp_path, capsys):
    assert main(["export", "telemetry", "--run", "0", "--out", str(tmp_path / "t")]) == 2
    assert "scenario.kind: export writes the kinds ['rda-nav'], got 'telemetry'" in capsys.readouterr().err


def test_export_shows_its_progress_on_a_terminal(tmp_path, capsys, monkeypatch):
    """On a terminal (stderr a tty) `sarnav export` tells each interval as it is written; piped, it says nothing."""
    import sys

    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert main(["export", "rda-nav", "--set", "trajectory.duration=2.0", "--runs", "2", "--run", "1",
                 "--out", str(tmp_path / "rec")]) == 0
    err = capsys.readouterr().err
    assert "export: interval 1/2 written" in err and "export: interval 2/2 written" in err
    monkeypatch.setattr(sys.stderr, "isatty", lambda: False)
    assert main(["export", "rda-nav", "--set", "trajectory.duration=2.0", "--runs", "2", "--run", "1",
                 "--out", str(tmp_path / "rec2")]) == 0
    assert "export:" not in capsys.readouterr().err
