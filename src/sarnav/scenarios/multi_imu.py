"""Scenario kinds of Sun (2022) (extraction seed-003; docs/particles.md "Scenarios"): configuration and wiring of the
library experiments of ``sarnav.simulation.multi_imu`` into Monte Carlo campaigns: ``multi-imu-path1`` (path 1, eq.
5.21, three position sensors of Table 5.1), ``multi-imu`` (scenario ``multi-imu-adis``: 3 x ADIS16465 against one
NovAtel IMU-ISA-100C) and ``upf-flight`` (the one-hour flight, the UPF and the interpolated KF on the 3 kHz grid).

Every run is a pure function of the scenario and its seed. Records (``sarnav.simulation.fusion_records``): the states
are the position errors of the filters that have a covariance, ``source_error`` and ``source_ms`` every navigation
source; ``summary.json`` -> ``rmse`` per source.
"""

from __future__ import annotations

from typing import Sequence

from sarnav.analysis.sources import filter_nees_summary, rmse_ratio, source_rmse
from sarnav.errors import ConfigError
from sarnav.montecarlo.kind import ScenarioKind, validate_campaign
from sarnav.montecarlo.record import RunRecord
from sarnav.scenarios.fields import boolean as _bool
from sarnav.scenarios.fields import bounded_vector, choice, integer, number, number_list
from sarnav.scenarios.kind_base import one_seed_per_run
from sarnav.scenarios.registry import packaged
from sarnav.simulation.fusion_records import AXES, SOURCE_ATTRS
from sarnav.simulation.imu_rig import ADIS_LEVER_ARMS
from sarnav.simulation.multi_imu import (UPF_ATTRS, MultiImuParams, Path1Params, UpfParams,
                                         run_multi_imu_records, run_path1_records, run_upf_flight_records)

__all__ = ["SourceKind", "settle_time", "MultiImuPath1Kind", "MultiImuKind", "UpfFlightKind", "Path1Params", "MultiImuParams",
           "UpfParams"]

#: largest particle count of any filter (memory: runs x particles x 6 floats per filter)
MAX_PARTICLES = 100_000
#: smallest particle count: the filters use the cloud's covariance (the Gaussian-PF update and the NEES of the
#: 6-D [p, v] cloud), which is singular below d + 1 = 7 particles
MIN_PARTICLES = 7


def settle_time(cfg: dict, hi: float, duration: float, epoch: float, duration_key: str) -> float:
    """``filter.settle_s`` in [0, ``hi``] s (the filters' settling time, left out of the statistics), leaving at least
    one ``epoch`` [s] of the flight (``duration_key`` = ``duration`` [s]) after it."""
    settle = number(cfg, "filter", "settle_s", 0.0, hi, "s")
    if settle > duration - epoch:
        raise ConfigError("filter.settle_s", f"must leave at least one epoch ({epoch:g} s) before {duration_key} = "
                          f"{duration} s, got {settle}")
    return settle


class SourceKind(ScenarioKind):
    """Common part of the kinds that compare navigation sources (module docstring). Subclasses set ``kind``,
    ``parse(cfg)`` and ``run_batch(prm, seeds, run_ids) -> list[RunRecord]`` (a ``run_*_records`` of
    ``simulation``); ``filters(prm)`` and ``sources(prm)`` (names) are the parameters' own by default;
    ``gains(rmse)`` adds ratios to summary.json; ``scenario``: the registered scenario whose file is the default."""

    scenario = ""

    def default_config(self) -> dict:
        return packaged(self.scenario)

    def parse(self, cfg: dict):  # pragma: no cover - replaced by subclasses
        raise NotImplementedError

    def run_batch(self, prm, seeds, run_ids) -> list[RunRecord]:  # pragma: no cover - replaced by subclasses
        raise NotImplementedError

    def filters(self, prm) -> list[str]:
        return prm.filters()

    def sources(self, prm) -> list[str]:
        return prm.sources()

    #: summary.json ``gains``: name -> (numerator, denominator) of ``analysis.sources.rmse_ratio``; "sensors": the
    #: mean RMS of every single-sensor source
    gain_pairs: dict = {}

    def gains(self, rmse: dict) -> dict:
        sensors = [k for k in rmse if k.startswith("sensor")]
        pick = lambda name: sensors if name == "sensors" else name  # noqa: E731
        return {key: rmse_ratio(rmse, pick(a), pick(b)) for key, (a, b) in self.gain_pairs.items()}

    def validate(self, cfg: dict) -> None:
        self.parse(cfg)

    def state_names(self, cfg: dict) -> list[str]:
        return [f"{f}_p{a}" for f in self.filters(self.parse(cfg)) for a in AXES]

    def state_units(self, cfg: dict) -> list[str]:
        return ["m"] * len(self.state_names(cfg))

    def meas_names(self, cfg: dict) -> list[str]:
        return []

    def extra_attrs(self, cfg: dict) -> dict:
        return dict(SOURCE_ATTRS)

    def extra_coords(self, cfg: dict) -> dict:
        prm = self.parse(cfg)
        return {"source": (self.sources(prm), {"units": "", "description": "navigation sources"}),
                "axis": (list(AXES), {"units": "", "description": "NED axes of source_error"}),
                "filter": (self.filters(prm), {"units": "", "description": "filters with a covariance (the states)"})}

    def simulate(self, cfg: dict, run_ids: Sequence[int], seeds) -> list[RunRecord]:
        one_seed_per_run(run_ids, seeds)
        if len(run_ids) == 0:
            return []
        return self.run_batch(self.parse(cfg), list(seeds), list(run_ids))

    def summary_extras(self, results) -> dict:
        out = source_rmse(results)
        out["filter_nees"] = filter_nees_summary(results)
        gains = self.gains(out["rmse"])
        if gains:
            out["gains"] = gains
        return out

    def figures(self, results, outdir) -> list[str]:
        from pathlib import Path

        from sarnav.report.source_figures import plot_source_rmse

        return [plot_source_rmse(results, Path(outdir) / "rmse_per_source.png")]


# --- multi-imu-path1 ------------------------------------------------------------------------------------------

class MultiImuPath1Kind(SourceKind):
    """Sun (2022) simulated path 1 (module docstring)."""

    kind, scenario = "multi-imu-path1", "multi-imu-path1"

    def parse(self, cfg: dict) -> Path1Params:
        runs, _ = validate_campaign(cfg)
        duration = number(cfg, "path", "duration", 1.0, 600.0, "s")
        rate = number(cfg, "sensors", "rate_hz", 1.0, 100.0, "Hz")
        sig = number_list(cfg, "sensors", "sigma_m", 1e-4, 100.0, "m")
        settle = settle_time(cfg, 600.0, duration, 1.0 / rate, "path.duration")
        return Path1Params(runs, duration, sig, rate, integer(cfg, "filter", "n_particles", MIN_PARTICLES, MAX_PARTICLES),
                           number(cfg, "filter", "accel_psd", 1e-8, 1e4, "m^2/s^3"), settle,
                           number(cfg, "fusion", "fix_sigma_m", 1e-4, 100.0, "m"),
                           integer(cfg, "fusion", "n_draws", 1, 10_000), _bool(cfg, "fusion", "per_axis"))

    def run_batch(self, prm: Path1Params, seeds, run_ids) -> list[RunRecord]:
        return run_path1_records(prm, seeds, run_ids)

    gain_pairs = {"mean_over_sir": ("mean", "sir"),  # T18 (source: ~3)
                  "sir_over_fix": ("sir", "fix"),  # T16/T25: bounded by the weighting fix
                  "single_over_mean": ("sensors", "mean")}


# --- multi-imu (multi-imu-adis) -------------------------------------------------------------------------------

class MultiImuKind(SourceKind):
    """3 x ADIS16465 against one NovAtel (module docstring)."""

    kind, scenario = "multi-imu", "multi-imu-adis"

    def parse(self, cfg: dict) -> MultiImuParams:
        runs, _ = validate_campaign(cfg)
        duration = number(cfg, "flight", "duration", 10.0, 1800.0, "s")
        settle = settle_time(cfg, 1800.0, duration, 0.05, "flight.duration")
        rec = number(cfg, "output", "record_rate_hz", 0.1, 20.0, "Hz")
        stride = round(20.0 / rec)
        if abs(20.0 / rec - stride) > 1e-9:
            raise ConfigError("output.record_rate_hz", f"must divide the 20 Hz fix rate (20, 10, 5, 4, 2, 1, ...), got {rec}")
        sig = bounded_vector(cfg, "fix", "sigma_m", 1e-3, 100.0, unit="m")
        bias = bounded_vector(cfg, "fix", "bias_m", -100.0, 100.0, unit="m")
        return MultiImuParams(runs, duration, number(cfg, "flight", "speed", 5.0, 150.0, "m/s"),
                              integer(cfg, "imu", "n_adis", 1, len(ADIS_LEVER_ARMS)), sig, bias,
                              _bool(cfg, "fix", "shared"), integer(cfg, "filter", "n_particles", MIN_PARTICLES, MAX_PARTICLES),
                              number(cfg, "filter", "accel_psd_scale", 1e-6, 1e6), settle,
                              integer(cfg, "fusion", "n_draws", 1, 10_000), _bool(cfg, "fusion", "per_axis"),
                              _bool(cfg, "fusion", "virtual_imu"), int(stride))

    def run_batch(self, prm: MultiImuParams, seeds, run_ids) -> list[RunRecord]:
        return run_multi_imu_records(prm, seeds, run_ids)

    gain_pairs = {"single_over_mean": ("sensors", "mean"),  # T21 (source ~5; i.i.d. theory sqrt(S))
                  "mean_over_sir": ("mean", "sir"),  # T22 (source ~2)
                  "sir_over_novatel": ("sir", "novatel"),  # T23 (source ~1)
                  "single_over_novatel": ("sensors", "novatel")}  # T23: > 1


# --- upf-flight -----------------------------------------------------------------------------------------------

IMU_PRESETS = ("novatel-isa-100c", "adis16465")


class UpfFlightKind(SourceKind):
    """The UPF against the interpolated KF on a one-hour flight (module docstring)."""

    kind, scenario = "upf-flight", "upf-flight"

    def parse(self, cfg: dict) -> UpfParams:
        runs, _ = validate_campaign(cfg)
        duration = number(cfg, "flight", "duration", 120.0, 7200.0, "s")  # the climb / pattern / descent phases
        fix_rate = number(cfg, "fix", "rate_hz", 1.0, 100.0, "Hz")
        settle = settle_time(cfg, 7200.0, duration, 1.0 / fix_rate, "flight.duration")
        imu_rate = number(cfg, "imu", "rate_hz", 10.0, 2000.0, "Hz")
        out_rate = number(cfg, "output", "rate_hz", 1.0, 20_000.0, "Hz")
        rec = number(cfg, "output", "record_rate_hz", 0.01, fix_rate, "Hz")
        if abs(fix_rate / rec - round(fix_rate / rec)) > 1e-9:
            raise ConfigError("output.record_rate_hz", f"must divide fix.rate_hz = {fix_rate} Hz, got {rec}")
        if duration * fix_rate > 1e6 or duration * max(out_rate, imu_rate) > 1e9:
            raise ConfigError("flight.duration", f"{duration} s at these rates is too long (at most 1e6 fixes, 1e9 epochs)")
        sig = bounded_vector(cfg, "fix", "sigma_m", 1e-3, 100.0, unit="m")
        return UpfParams(runs, duration, number(cfg, "flight", "speed", 5.0, 150.0, "m/s"),
                         number(cfg, "flight", "climb_rate", 0.0, 20.0, "m/s"), choice(cfg, "imu", "preset", IMU_PRESETS),
                         imu_rate, sig, fix_rate, integer(cfg, "filter", "n_particles", MIN_PARTICLES, MAX_PARTICLES),
                         number(cfg, "filter", "accel_psd_scale", 1e-6, 1e6),
                         choice(cfg, "filter", "noise_at", ("fix", "imu")), settle, out_rate, rec,
                         _bool(cfg, "filter", "kf_coriolis"))

    def extra_attrs(self, cfg: dict) -> dict:
        return dict(UPF_ATTRS)

    def run_batch(self, prm: UpfParams, seeds, run_ids) -> list[RunRecord]:
        return run_upf_flight_records(prm, seeds, run_ids)

    gain_pairs = {"upf_over_pf": ("upf", "pf"),  # T10: 3 kHz output no worse than at the fixes
                  "pf_over_kf": ("pf", "kf"),  # T11: < 1
                  "upf_over_kf_interp": ("upf", "kf-interp")}

    def summary_extras(self, results) -> dict:
        from sarnav.tomlio import parse_toml

        out = super().summary_extras(results)
        st = results["settle_time"].values
        secs = results["filter_seconds"].values.mean(axis=0)
        duration = float(parse_toml(results.attrs["scenario"])["flight"]["duration"])
        out["cloud_settle_time_s"] = {"max": float(st.max()), "mean": float(st.mean())}  # T13 (source < 75 s)
        out["pf_over_kf_cost"] = float(secs[0] / secs[1]) if secs[1] > 0 else None  # T12 (source 5)
        out["upf_realtime_ratio"] = duration / float(secs[0]) if secs[0] > 0 else None  # flight s per wall s
        return out

    def figures(self, results, outdir) -> list[str]:
        from pathlib import Path

        from sarnav.report.source_figures import plot_cloud_variance

        return super().figures(results, outdir) + [plot_cloud_variance(results, Path(outdir) / "cloud_variance.png")]
