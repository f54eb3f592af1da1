"""The table of named scenarios and the table of scenario kinds.

``SCENARIOS`` has one line per named scenario: name, kind, one-line description, and where its
default configuration comes from: ``"file:"``, the TOML file shipped with the package,
``scenarios/defaults/<name>.toml`` (:func:`packaged`; data, with a comment on every value the sources leave open),
``"module:function"`` (imported lazily) or ``"kind:"`` (the kind's own ``default_config()``). ``KINDS`` maps ``scenario.kind`` to the ``ScenarioKind`` class
(``"module:Class"``, imported lazily). A kind name that itself looks like ``"package.module:Class"``
is imported directly (plug-in kinds living outside sarnav, and the toy kinds of the tests).
"""

from __future__ import annotations

import copy
import functools
import importlib
from dataclasses import dataclass
from importlib import resources

from sarnav.errors import ConfigError
from sarnav.montecarlo.kind import ScenarioKind
from sarnav.tomlio import parse_toml

__all__ = ["ScenarioEntry", "SCENARIOS", "KINDS", "list_scenarios", "get_scenario", "get_kind", "template_for_kind",
           "template_for", "optional_keys", "packaged", "DEFAULT_SCENARIO", "DEFAULT_RUNS"]


@dataclass(frozen=True)
class ScenarioEntry:
    """One named scenario: ``factory`` is ``"file:"`` (:func:`packaged`), ``"module:function"`` or ``"kind:"``."""

    name: str
    kind: str
    description: str
    factory: str


#: ``scenario.kind`` -> ``"module:Class"``
KINDS: dict[str, str] = {
    "telemetry": "sarnav.scenarios.telemetry:TelemetryKind",
    "study": "sarnav.scenarios.study:StudyKind",
    "rda-nav": "sarnav.scenarios.rda_nav:RdaNavKind",
    "bpa-sensitivity": "sarnav.scenarios.bpa_sensitivity:BpaSensitivityKind",
    "image": "sarnav.scenarios.imaging:ImageKind",
    "spacecraft": "sarnav.scenarios.spacecraft:SpacecraftKind",
    "spacecraft-closed-loop": "sarnav.scenarios.spacecraft_closed_loop:ClosedLoopKind",
    "multi-imu-path1": "sarnav.scenarios.multi_imu:MultiImuPath1Kind",
    "multi-imu": "sarnav.scenarios.multi_imu:MultiImuKind",
    "upf-flight": "sarnav.scenarios.multi_imu:UpfFlightKind",
    "nav-source-focus": "sarnav.scenarios.nav_focus:NavFocusKind",
    "multi-imu-sar": "sarnav.scenarios.multi_imu_sar:MultiImuSarKind",
    "quality-sweep": "sarnav.scenarios.quality_sweep:QualitySweepKind",
    "gpsd-search": "sarnav.scenarios.gpsd_search:GpsdSearchKind",
    "quality-nav": "sarnav.scenarios.quality_nav:QualityNavKind",
}

# fmt: off
#: one line per scenario (name, kind, description, default-config factory)
SCENARIOS: tuple[ScenarioEntry, ...] = (
    ScenarioEntry("telemetry", "telemetry", "Thesis ch. 3: INS + altimeter/range/range-rate EKF, one known target, Monte Carlo (Figs 3.4-3.7)", "file:"),
    ScenarioEntry("telemetry-imu-grade", "study", "Thesis Table 3.2 / Fig 3.8: position 3-sigma for consumer, tactical, navigation IMUs", "file:"),
    ScenarioEntry("telemetry-noise", "study", "Thesis Table 3.3 / Fig 3.9: range, range-rate, altimeter noise x10 one at a time", "file:"),
    ScenarioEntry("telemetry-geometry", "study", "Thesis Table 3.4 / Figs 3.10-3.11: eight target locations", "file:"),
    ScenarioEntry("rda-nav", "rda-nav", "NAVIGATION paper / thesis ch. 5: INS aided by range and cross-range from RDA images", "file:"),
    ScenarioEntry("rda-nav-flexsar", "rda-nav", "Paper Tables 4-6: simulated FlexSAR-like flight at 60 m/s", "file:"),
    ScenarioEntry("rda-nav-terrain", "rda-nav", "rda-nav over terrain with speckle clutter and a reference from another pass", "file:"),
    ScenarioEntry("rda-nav-robustness", "study", "rda-nav outside its calibration: SNR, clutter density, reference pass offset (sweep figures)", "file:"),
    ScenarioEntry("bpa-sensitivity", "bpa-sensitivity", "Thesis ch. 4: BPA image shifts and blur from navigation errors", "file:"),
    ScenarioEntry("point-target", "image", "One point target, 1-s X-band aperture at 60 m/s: IRW, PSLR, ISLR against theory (sarnav image)", "file:"),
    ScenarioEntry("spacecraft-tc1", "spacecraft", "Pogorelsky et al. 2022 TC-1 open loop: LEO MEKF, misalignment 0.1 deg, Lear underweighting, 100 runs x 600 s", "file:"),
    ScenarioEntry("spacecraft-tc2", "spacecraft", "Pogorelsky et al. 2022 TC-2 open loop: LEO MEKF, misalignment 0.01 deg, 100 runs x 600 s", "file:"),
    ScenarioEntry("spacecraft-closed-loop", "spacecraft-closed-loop", "Pogorelsky et al. 2022 closed loop, simulated: L-band echoes, autofocus v_ic, registration r_f, 3 updates", "file:"),
    ScenarioEntry("scatterers", "image", "Random field of point scatterers (Poisson, Rayleigh amplitudes, seeded) (sarnav image)", "file:"),
    ScenarioEntry("multi-imu-path1", "multi-imu-path1", "Sun 2022 path 1 (eq. 5.21): three position sensors (Table 5.1), one PF each, mean vs SIR fusion", "file:"),
    ScenarioEntry("multi-imu-adis", "multi-imu", "Sun 2022 Figs 5.10-5.13: 3 x ADIS16465 PFs fused (SIR, mean, virtual IMU) vs one NovAtel IMU-ISA-100C", "file:"),
    ScenarioEntry("upf-flight", "upf-flight", "Sun 2022 Figs 5.8, 5.26: 1-h flight, 200 Hz IMU + 20 Hz fix, 2000-particle UPF vs interpolated KF at 3 kHz", "file:"),
    ScenarioEntry("nav-source-focus", "nav-source-focus", "Sun 2022 Figs 6.5-6.9: Ku-band cart BPA focused with truth / UPF / KF / splines / 3-ADIS SIR / NovAtel positions (focus.csv)", "file:"),
    ScenarioEntry("multi-imu-sar-fix", "multi-imu-sar", "GPS-denied multi-IMU fusion: 3 x ADIS16465 + NovAtel PFs aided and SIR-weighted by SAR range/cross-range fixes (rda-nav flight)", "file:"),
    ScenarioEntry("quality-sweep", "quality-sweep", "Hathaway 2023 Figs. 4.1-4.8: kurtosis / entropy of BPA images vs along- and cross-track velocity error", "file:"),
    ScenarioEntry("gpsd-search", "gpsd-search", "Hathaway 2023 Alg. 3.3: reduced Table 4.1 sweep (rho.csv), controls, searches that span the bias (~2 min)", "file:"),
    ScenarioEntry("gpsd-search-table41", "gpsd-search", "Hathaway 2023 Table 4.1: the full velocity-offset search sweep, all six (S_i, L)", "file:"),
    ScenarioEntry("quality-nav", "quality-nav", "INS aided by the best-focus along-track velocity of its own BPA images (no map), 100 runs", "file:"),
)
# fmt: on

#: what ``sarnav run`` runs without a scenario argument (issue 4: the image-aided flight) ...
DEFAULT_SCENARIO = "rda-nav"
#: ... with this many runs unless ``--runs`` is given: a few minutes on 2 cores; the full 200-run
#: campaign of the paper is ``sarnav run rda-nav``
DEFAULT_RUNS = 20

_KIND_INSTANCES: dict[str, ScenarioKind] = {}


def _import(path: str, field: str):
    module_name, _, attr = path.partition(":")
    try:
        obj = importlib.import_module(module_name)
    except ImportError as err:
        raise ConfigError(field, f"cannot import {module_name!r} ({err})") from None
    for part in attr.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            raise ConfigError(field, f"{module_name!r} has no {attr!r}") from None
    return obj


def list_scenarios() -> list[tuple[str, str]]:
    """(name, one-line description) of every registered scenario, in table order."""
    return [(e.name, e.description) for e in SCENARIOS]


def _entry(name: str) -> ScenarioEntry:
    for e in SCENARIOS:
        if e.name == name:
            return e
    known = ", ".join(e.name for e in SCENARIOS)
    raise ConfigError("scenario", f"unknown scenario {name!r} (known: {known}; or give a .toml file)")


def get_kind(kind: str) -> ScenarioKind:
    """The ``ScenarioKind`` instance handling ``scenario.kind == kind`` (imported on first use)."""
    if kind in _KIND_INSTANCES:
        return _KIND_INSTANCES[kind]
    if kind in KINDS:
        path = KINDS[kind]
    elif ":" in kind:
        path = kind
    else:
        known = ", ".join(sorted(KINDS))
        raise ConfigError("scenario.kind", f"unknown kind {kind!r} (known: {known}, or 'package.module:Class')")
    cls = _import(path, "scenario.kind")
    if not (isinstance(cls, type) and issubclass(cls, ScenarioKind)):
        raise ConfigError("scenario.kind", f"{path!r} is not a ScenarioKind subclass")
    inst = cls()
    _KIND_INSTANCES[kind] = inst
    return inst


@functools.cache
def _packaged_text(name: str) -> str:
    return resources.files("sarnav.scenarios").joinpath("defaults", f"{name}.toml").read_text(encoding="utf-8")


def packaged(name: str) -> dict:
    """The default configuration of the registered scenario ``name`` as shipped, ``scenarios/defaults/<name>.toml``.

    A study's ``[base] registered = "<scenario>"`` is that registered scenario, whose campaign seed the study takes
    (common random numbers across the cases)."""
    cfg = parse_toml(_packaged_text(name), f"sarnav/scenarios/defaults/{name}.toml")
    base = cfg.get("base")
    if isinstance(base, dict) and "registered" in base:
        cfg["base"] = get_scenario(base["registered"])
        cfg["campaign"]["seed"] = cfg["base"].pop("campaign")["seed"]
    return cfg


def get_scenario(name: str) -> dict:
    """A fresh copy of the default configuration of the registered scenario ``name``."""
    e = _entry(name)
    if e.factory == "file:":
        cfg = packaged(e.name)
    elif e.factory == "kind:":
        kind = get_kind(e.kind)
        make = getattr(kind, "default_config", None)
        if make is None:
            raise ConfigError("scenario", f"kind {e.kind!r} has no default_config()")
        cfg = make()
    else:
        cfg = _import(e.factory, "scenario")()
    cfg = copy.deepcopy(cfg)
    scen = cfg.setdefault("scenario", {})
    scen["name"] = e.name
    scen["kind"] = e.kind
    scen.setdefault("description", e.description)
    return cfg


def template_for_kind(kind: str) -> dict | None:
    """Reference configuration for files of this kind: the scenario named like the kind, the kind's
    ``default_config()``, or the first registered scenario of the kind, if any."""
    for e in SCENARIOS:
        if e.name == kind and e.kind == kind:
            return get_scenario(kind)
    make = getattr(get_kind(kind), "default_config", None)
    if callable(make):
        return copy.deepcopy(make())
    for e in SCENARIOS:  # else the first registered scenario of the kind
        if e.kind == kind:
            return get_scenario(e.name)
    return None


def template_for(kind: str, name: str | None = None) -> dict | None:
    """Reference configuration for a file of ``kind`` whose ``scenario.name`` is ``name``: the registered scenario
    of that name when it is of the same kind, else :func:`template_for_kind`."""
    for e in SCENARIOS:
        if e.name == name and e.kind == kind:
            return get_scenario(name)
    return template_for_kind(kind)


def optional_keys(kind: str) -> set[str]:
    """Dotted keys a kind accepts although its reference configuration leaves them out.

    Read from the kind's ``optional_keys()`` when it has one (an optional extension of the
    ``ScenarioKind`` contract).
    """
    try:
        inst = get_kind(kind)
    except ConfigError:
        return set()
    fn = getattr(inst, "optional_keys", None)
    return set(fn()) if callable(fn) else set()
