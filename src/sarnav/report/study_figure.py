"""Study outputs: the comparison figure of the filter 3σ of each case on one set of panels (thesis Figs 3.8-3.11,
where line styles tell the cases apart), the sweep figures and ``study.json`` (:func:`write_study_files`)."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from sarnav.report.figures import save_png

__all__ = ["plot_study_comparison", "write_study_json", "write_study_files", "default_state_unit", "study_figure_specs",
           "LINE_STYLES"]

#: line styles of the cases, in order, where a case names none (== sarnav.scenarios.study.STYLES)
LINE_STYLES = ("-", "--", "-.", ":")


def default_state_unit(name: str) -> str:
    """The unit of a standard error state (``pN`` -> m, ``vE`` -> m/s, ``thD`` -> rad, ``baX`` -> m/s^2, ``bgZ``
    -> rad/s, from :class:`sarnav.filters.layout.ErrorStateLayout`); "" for any other name (results.nc
    ``state_units`` is the authority)."""
    from sarnav.filters.layout import ErrorStateLayout

    layout = ErrorStateLayout()
    return dict(zip(layout.state_names(), layout.state_units())).get(name, "")


def study_figure_specs(cfg: dict) -> list[dict]:
    """The comparison figures of a study scenario: its ``[[figures]]`` (name, title, cases, states) or one figure
    ``3sigma`` of every case over ``study.states`` (default pN, pE, pD) titled with the description."""
    labels = [c["label"] for c in cfg["cases"]]
    states = cfg.get("study", {}).get("states", ["pN", "pE", "pD"])
    figs = cfg.get("figures") or [{"name": "3sigma", "title": cfg["scenario"].get("description", ""), "cases": labels,
                                   "states": states}]
    return [{"name": f["name"], "title": f.get("title", ""), "cases": f.get("cases", labels),
             "states": f.get("states", states)} for f in figs]


def plot_study_comparison(cases: Sequence[tuple], state_names: Sequence[str], states: Sequence[str], title: str, path,
                          state_units: Sequence[str] | None = None) -> str:
    """Panels (one per state in ``states``) with one 3σ curve per case.

    Parameters
    ----------
    cases : (label, time (T,), sigma3 (T, S), line style) per case; sigma3 is 3 × mean filter 1σ.
    state_names : the S state names (columns of sigma3).
    states : which states to draw, e.g. ("pN", "pE", "pD").
    state_units : the S units (results.nc coordinate ``state_units``) for the y axes; without them the standard
        error-state units (:func:`default_state_unit`) are used and a state outside them gets no unit.
    """
    names = list(state_names)
    fig = Figure(figsize=(8, 2.4 * len(states)), constrained_layout=True)
    axes = fig.subplots(len(states), 1, sharex=True, squeeze=False)[:, 0]
    for k, (label, t, sig3, style) in enumerate(cases):
        color = f"C{k % 10}"
        for ax, s in zip(axes, states):
            ax.plot(np.asarray(t), np.asarray(sig3)[:, names.index(s)], style, color=color, lw=1.3, label=label)
    for ax, s in zip(axes, states):
        unit = state_units[names.index(s)] if state_units is not None else default_state_unit(s)
        ax.set_ylabel(f"{s} 3σ [{unit}]" if unit else f"{s} 3σ")
        ax.set_yscale("log")
        ax.grid(True, which="both", lw=0.3)
    axes[0].legend(fontsize=8, ncol=min(4, len(cases)))
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(title)
    return save_png(fig, path)


def write_study_json(path, result: dict) -> None:
    """``study.json`` (atomic): each case's final 1-sigma / 3-sigma and time-averaged 3-sigma per state."""
    import json

    from sarnav.montecarlo.store import atomic_write_text

    atomic_write_text(path, json.dumps(result, indent=2) + "\n")


def sweep_points(summaries: Sequence[dict], x: Sequence[float]) -> dict:
    """What a sweep figure plots, from each case's ``summary.json`` (in sweep order): registration std and predicted
    sigma per axis, mean NEES and its band, NIS/dof and its band, final position 3-sigma per axis (None where a case
    has no such statistic)."""
    def reg(s, axis, key):
        return (s.get("registration", {}).get(axis) or {}).get(key)

    out = {"x": [float(v) for v in x]}
    for axis in ("range", "cross"):
        out[f"{axis}_std"] = [reg(s, axis, "std") for s in summaries]
        out[f"{axis}_predicted"] = [reg(s, axis, "predicted_sigma_rms") for s in summaries]
    out["nees"] = [s["nees"]["time_average"] for s in summaries]
    out["nees_band"] = [s["nees"]["band"] for s in summaries]
    out["nis_per_dof"] = [(s.get("nis") or {}).get("per_dof") for s in summaries]
    out["nis_band"] = [(s.get("nis") or {}).get("per_dof_band") for s in summaries]
    for st in ("pN", "pE", "pD"):
        out[f"{st}_final_3sigma"] = [s["states"][st]["final_3sigma"] for s in summaries]
    out["rejected"] = [sum((s.get("sar_updates") or {}).get("rejected", {}).values()) for s in summaries]
    return out


def plot_sweep(points: dict, x_label: str, title: str, path) -> str:
    """Four panels against the swept quantity: registration sigma predicted (lines) and measured (markers) per axis
    [m, log]; mean NEES with its 95 % band; NIS per dof with its band; final position 3-sigma N, E, D [m, log]."""
    fig = Figure(figsize=(11, 8), layout="constrained")
    ax = fig.subplots(2, 2)
    x = np.asarray(points["x"], dtype=float)

    def arr(key):
        return np.array([np.nan if v is None else v for v in points[key]], dtype=float)

    for axis, colour, name in (("range", "C0", "range"), ("cross", "C1", "along track")):
        ax[0, 0].plot(x, arr(f"{axis}_predicted"), "-", color=colour, label=f"{name}: predicted (rms)")
        ax[0, 0].plot(x, arr(f"{axis}_std"), "o", color=colour, label=f"{name}: measured std")
    ax[0, 0].set_yscale("log")
    ax[0, 0].set_ylabel("registration 1-sigma [m]")
    ax[0, 0].legend(fontsize=7)
    for panel, key, band, label in ((ax[0, 1], "nees", "nees_band", "mean NEES [-]"),
                                    (ax[1, 0], "nis_per_dof", "nis_band", "NIS / dof [-]")):
        b = np.array([[np.nan, np.nan] if v is None else v for v in points[band]], dtype=float)
        panel.fill_between(x, b[:, 0], b[:, 1], color="0.85", label="95 % band")
        panel.plot(x, arr(key), "o-", color="k", label="campaign")
        panel.set_ylabel(label)
        panel.legend(fontsize=7)
    for st, colour in (("pN", "C0"), ("pE", "C1"), ("pD", "C2")):
        ax[1, 1].plot(x, arr(f"{st}_final_3sigma"), "o-", color=colour, label=f"{st}")
    ax[1, 1].set_yscale("log")
    ax[1, 1].set_ylabel("final position 3-sigma [m]")
    ax[1, 1].legend(fontsize=7)
    for a in ax.flat:
        a.set_xlabel(x_label)
        a.grid(True, alpha=0.3)
    fig.suptitle(title)
    return save_png(fig, path)


def write_study_files(cfg: dict, kind, outcomes, out: Path, figures: bool) -> dict:
    """A finished study's files in ``out``: each case's campaign figures (``figures``, drawn with ``kind``, the base
    scenario's kind), the comparison and sweep figures and ``study.json``, whose content it returns; ``outcomes``:
    ``montecarlo.study.CaseOutcome`` per case."""
    from sarnav.report.figures import write_campaign_figures
    from sarnav.tomlio import dump_toml

    by_label = {o.label: o for o in outcomes}
    cases_out = [{"label": case["label"], "set": case.get("set", {}), "dir": case["label"],
                  "states": by_label[case["label"]].states} for case in cfg["cases"]]
    if figures:
        for o in outcomes:
            write_campaign_figures(o.result.dataset, out / o.label, kind=kind)
    fig_paths = []
    if figures:
        style = {c["label"]: c.get("style", LINE_STYLES[k % len(LINE_STYLES)]) for k, c in enumerate(cfg["cases"])}
        for spec in study_figure_specs(cfg):
            sel = [(lab, *by_label[lab].curves[:2], style[lab]) for lab in spec["cases"]]
            path = out / f"study_{spec['name']}.png"
            fig_paths.append(plot_study_comparison(sel, by_label[spec["cases"][0]].curves[2], spec["states"],
                                                   spec["title"], path))
    sweeps = {}
    for sw in cfg.get("sweeps", []):
        sweeps[sw["name"]] = sweep_points([by_label[lab].result.summary for lab in sw["cases"]], sw["x"])
        if figures:
            fig_paths.append(plot_sweep(sweeps[sw["name"]], sw.get("x_label", ""), sw.get("title", ""),
                                        out / f"sweep_{sw['name']}.png"))
    result = {
        "study": cfg["scenario"]["name"],
        "runs": cfg["campaign"]["runs"],
        "seed": cfg["campaign"]["seed"],
        "complete": True,
        "cases": cases_out,
        "figures": [Path(p).name for p in fig_paths],
        **({"sweeps": sweeps} if sweeps else {}),
        "scenario_toml": dump_toml(cfg),
    }
    write_study_json(out / "study.json", result)
    return result
