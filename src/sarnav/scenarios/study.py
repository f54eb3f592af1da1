"""Studies: one base scenario run as several Monte Carlo campaigns that differ in a few values (docs/scenarios/studies.md).

A study scenario (kind ``"study"``) has ``[campaign]`` (used by every case: the same seed, common random numbers),
``[study] states``, ``[base]`` (a complete scenario of another kind), ``[[cases]]`` (``label``, ``style``, ``set`` of
dotted keys), optional ``[[figures]]`` and ``[[sweeps]]`` (statistics against a swept value). :func:`run_study` runs
each case as a campaign into ``OUT/<label>/`` (``montecarlo.study.run``) and writes the comparison and sweep figures
and ``OUT/study.json``. The chapter 3 studies of Lindstrom (2020) and the rda-nav robustness study are registered
scenarios (``defaults/telemetry-imu-grade.toml`` ...). Configuration and wiring only: :func:`parse`, the kind, the
figures and ``study.json``.
"""

from __future__ import annotations

import copy
import re
from pathlib import Path


from sarnav.errors import ConfigError
from sarnav.montecarlo.kind import ScenarioKind
from sarnav.montecarlo.study import StudyCase, StudyParams, run
from sarnav.scenarios.config import set_value, validate_scenario
from sarnav.scenarios.fields import known_keys

__all__ = ["StudyKind", "case_config", "parse", "run_study", "STYLES"]

STYLES = ("-", "--", "-.", ":")
_LABEL_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


def _base_kind(cfg: dict) -> ScenarioKind:
    from sarnav.scenarios.registry import get_kind

    base = cfg.get("base")
    if not isinstance(base, dict) or not isinstance(base.get("scenario"), dict):
        raise ConfigError("base", "missing table [base] with a complete scenario ([base.scenario] kind, ...)")
    kind = base["scenario"].get("kind")
    if not isinstance(kind, str) or not kind or kind == "study":
        raise ConfigError("base.scenario.kind", f"must name a kind other than 'study', got {kind!r}")
    return get_kind(kind)


def case_config(cfg: dict, index: int) -> dict:
    """The complete scenario of case ``index``: base + the case's ``set`` + the study's campaign.

    Errors name the case's field, e.g. ``cases[2].set.imu.grade``.
    """
    from sarnav.scenarios.registry import optional_keys

    case = cfg["cases"][index]
    out = case_config_shallow(cfg)
    out["scenario"]["name"] = f"{cfg['scenario']['name']}.{case['label']}"
    opt = optional_keys(out["scenario"]["kind"])
    for key, value in case.get("set", {}).items():
        try:
            set_value(out, key, value, opt)
        except ConfigError as err:
            raise ConfigError(f"cases[{index}].set.{err.field}", err.message) from None
    return out


def _case_field(case: dict, index: int, field: str) -> str:
    """The key of the study file that a case's error on ``field`` (a key of the case's scenario) is about: the
    case's ``set`` entry when it sets it (or a table above it), the study's own ``[campaign]`` and ``scenario.name``,
    else ``base.<field>``."""
    if field.startswith("cases["):
        return field
    for key in case.get("set", {}):
        if field == key or field.startswith((f"{key}.", f"{key}[")) or key.startswith(f"{field}."):
            return f"cases[{index}].set.{key}"
    if field.split(".")[0].split("[")[0] == "campaign" or field == "scenario.name":
        return field
    return f"base.{field}"


class StudyKind(ScenarioKind):
    """Kind ``"study"``: validated here, run by :func:`run_study` (not through ``simulate``)."""

    kind = "study"

    def validate(self, cfg: dict) -> None:
        kind = _base_kind(cfg)
        study = cfg.get("study", {})
        if not isinstance(study, dict):
            raise ConfigError("study", "must be a table")
        cases = cfg.get("cases")
        if not isinstance(cases, list) or not cases:
            raise ConfigError("cases", "must be a non-empty array of tables [[cases]] (label, set)")
        state_names = kind.state_names(case_config_shallow(cfg))
        labels = []
        for i, case in enumerate(cases):
            if not isinstance(case, dict):
                raise ConfigError(f"cases[{i}]", "must be a table with label and set")
            known_keys(case, ("label", "set", "style"), f"cases[{i}]")
            label = case.get("label")
            if not isinstance(label, str) or not _LABEL_RE.match(label):
                raise ConfigError(f"cases[{i}].label", f"must be a name of letters, digits, '_.-', got {label!r}")
            if label in labels:
                raise ConfigError(f"cases[{i}].label", f"duplicate label {label!r}")
            labels.append(label)
            if not isinstance(case.get("set", {}), dict):
                raise ConfigError(f"cases[{i}].set", "must be a table of dotted keys, e.g. {\"imu.grade\" = \"consumer\"}")
            if case.get("style", "-") not in STYLES:
                raise ConfigError(f"cases[{i}].style", f"must be one of {STYLES}, got {case.get('style')!r}")
            sub = case_config(cfg, i)
            try:
                validate_scenario(sub, kind)
            except ConfigError as err:
                raise ConfigError(_case_field(case, i, err.field), f"{err.message} (case {label!r})") from None
        for name in study.get("states", []):
            if name not in state_names:
                raise ConfigError("study.states", f"unknown state {name!r} (states: {', '.join(state_names)})")
        for j, fig in enumerate(cfg.get("figures", [])):
            if not isinstance(fig, dict) or not isinstance(fig.get("name"), str) or not _LABEL_RE.match(fig["name"]):
                raise ConfigError(f"figures[{j}].name", "must be a name of letters, digits, '_.-'")
            for lab in fig.get("cases", labels):
                if lab not in labels:
                    raise ConfigError(f"figures[{j}].cases", f"unknown case {lab!r} (cases: {', '.join(labels)})")
            for name in fig.get("states", []):
                if name not in state_names:
                    raise ConfigError(f"figures[{j}].states", f"unknown state {name!r}")

        _validate_sweeps(cfg, labels)

    def state_names(self, cfg: dict) -> list[str]:
        return _base_kind(cfg).state_names(case_config_shallow(cfg))

    def state_units(self, cfg: dict) -> list[str]:
        return _base_kind(cfg).state_units(case_config_shallow(cfg))

    def meas_names(self, cfg: dict) -> list[str]:
        return _base_kind(cfg).meas_names(case_config_shallow(cfg))

    def meas_units(self, cfg: dict) -> list[str]:
        return _base_kind(cfg).meas_units(case_config_shallow(cfg))

    def simulate(self, cfg, run_ids, seeds):
        raise ConfigError("scenario.kind", "a study runs as one campaign per case: use run_study / `sarnav run`")

    def run_scenario(self, cfg: dict, out, **options) -> dict:
        """What ``sarnav run`` calls for kinds that are not a single campaign: :func:`run_study`."""
        return run_study(cfg, out, **options)


def _validate_sweeps(cfg: dict, labels: list[str]) -> None:
    sweeps = cfg.get("sweeps", [])
    if not isinstance(sweeps, list):
        raise ConfigError("sweeps", "must be an array of tables [[sweeps]] (name, title, x_label, x, cases)")
    for j, sw in enumerate(sweeps):
        if not isinstance(sw, dict) or not isinstance(sw.get("name"), str) or not _LABEL_RE.match(sw["name"]):
            raise ConfigError(f"sweeps[{j}].name", "must be a name of letters, digits, '_.-'")
        cases, x = sw.get("cases"), sw.get("x")
        if not isinstance(cases, list) or not cases or any(c not in labels for c in cases):
            raise ConfigError(f"sweeps[{j}].cases", f"must list cases of this study ({', '.join(labels)}), got {cases!r}")
        if (not isinstance(x, list) or len(x) != len(cases)
                or any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in x)):
            raise ConfigError(f"sweeps[{j}].x", f"must be {len(cases)} numbers, one per case, got {x!r}")
        for key in ("title", "x_label"):
            if not isinstance(sw.get(key, ""), str):
                raise ConfigError(f"sweeps[{j}].{key}", "must be a string")


def case_config_shallow(cfg: dict) -> dict:
    """The base scenario with the study's campaign (no case applied)."""
    out = copy.deepcopy(cfg["base"])
    out["campaign"] = copy.deepcopy(cfg["campaign"])
    return out


def parse(cfg: dict) -> StudyParams:
    """The checked study (``StudyKind.validate``): each case's complete scenario (:func:`case_config`) and the base
    kind; ConfigError names the first bad key."""
    validate_scenario(cfg)
    return StudyParams(kind=_base_kind(cfg),
                       cases=tuple(StudyCase(c["label"], case_config(cfg, i)) for i, c in enumerate(cfg["cases"])))


def run_study(cfg: dict, out, figures: bool = True, **campaign_options) -> dict:
    """Run every case of the study ``cfg`` into ``out/<label>/`` and write ``out/study.json``.

    ``campaign_options`` go to :func:`sarnav.montecarlo.study.run` (executor, workers, scheduler) and
    :func:`sarnav.montecarlo.campaign.run_campaign` (resume, quiet, chunk_size, overwrite). Returns the
    ``study.json`` content.
    """
    from sarnav.montecarlo.outdir import OutputFolder, identity
    from sarnav.report.study_figure import write_study_files

    prm = parse(cfg)
    out = Path(out)
    with OutputFolder(out, identity(cfg), resume=campaign_options.get("resume", False),
                      overwrite=campaign_options.get("overwrite", False)):
        (out / "study.json").unlink(missing_ok=True)
        outcomes = run(prm, out, **campaign_options)
        return write_study_files(cfg, prm.kind, outcomes, out, figures)
