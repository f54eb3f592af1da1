"""Figures of ``report.html`` of ``sarnav navigate`` (docs/navigate.md), drawn from its output files.

* :func:`track_figure`: the estimated track (north/east) and the update points coloured by the status of their SAR
  pairs, over the reference: the reference points (anchor and map) and, where formed, amplitude images of the
  reference pass (:func:`reference_tiles`: back-projection, ``imaging.backprojection``, of the recording's reference
  CPHD along its trusted positions onto a ground grid around the aperture's anchors);
* :func:`error_figure`: truth minus estimate of a block of three states (errors.csv) against the filter's ±3σ;
* :func:`gnss_figure`: estimate minus GNSS position against ±3 sqrt(σ_est² + σ_GNSS²) (the two independent
  1-sigma of the difference combined);
* :func:`consistency_figure`: NEES per epoch (with truth) and NIS per update against their two-sided 95 %
  chi-square bands of one run (``analysis.consistency.chi2_band``; Bar-Shalom et al. 2001 §5.4).

Matplotlib's object API (no pyplot), as :mod:`sarnav.report.figures`. Every function returns a ``Figure``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from matplotlib.figure import Figure

from sarnav.analysis.consistency import chi2_band

__all__ = ["STATUS_COLOURS", "ERROR_BLOCKS", "ReferenceTile", "reference_tiles", "update_status", "track_figure",
           "error_figure", "gnss_difference", "gnss_figure", "consistency_figure", "pick_apertures"]

#: colour of an update point by the status of its SAR pairs ("none": an update without a SAR aperture)
STATUS_COLOURS = {"fused": "tab:green", "rejected": "tab:red", "skipped": "0.55", "none": "tab:blue"}
#: (title, error_* / sigma_* column names, unit label, scale from SI to the unit drawn)
ERROR_BLOCKS = (("Position error", ("north", "east", "down"), "m", 1.0),
                ("Velocity error", ("v_north", "v_east", "v_down"), "m/s", 1.0),
                ("Attitude error", ("th_north", "th_east", "th_down"), "mrad", 1e3))
#: ground pixels of one reference tile at most (the pixel size grows for a wider spread of points)
MAX_TILE_PIXELS = 60_000
#: margin [m] around a tile's anchors
TILE_MARGIN_M = 30.0


@dataclass(frozen=True)
class ReferenceTile:
    """Amplitude ``amplitude`` (Ny, Nx) of the reference pass of ``aperture`` on the ground grid ``north`` (Ny,) x
    ``east`` (Nx,) [m] (NED, the recording's local frame)."""

    aperture: int
    north: np.ndarray
    east: np.ndarray
    amplitude: np.ndarray


def pick_apertures(n_apertures: int, wanted, at_most: int) -> list[int]:
    """At most ``at_most`` apertures of ``wanted`` (indices < ``n_apertures``), spread evenly over them."""
    wanted = sorted({int(u) for u in wanted if 0 <= int(u) < n_apertures})
    if len(wanted) <= at_most:
        return wanted
    idx = np.unique(np.linspace(0, len(wanted) - 1, at_most).round().astype(int))
    return [wanted[i] for i in idx]


def reference_tiles(rec, apertures, resolution_m: float | None = None) -> list[ReferenceTile]:
    """Amplitude images of the reference passes of ``apertures`` of the recording ``rec``: each back-projected
    (``imaging.backprojection.backproject``, linear interpolation: a picture, 4x cheaper than the default's
    accuracy, invisible at the figure's 40-dB scale) along the pass's trusted positions onto a
    ground grid (down = the anchors' mean) covering the aperture's anchors plus ``TILE_MARGIN_M``; pixels a quarter
    of the slant-range resolution c/2B across (``resolution_m`` overrides it) and four times that along north,
    coarser when the tile would exceed ``MAX_TILE_PIXELS``."""
    from sarnav.imaging.backprojection import backproject
    from sarnav.imaging.grid import GroundGrid

    radar = rec.manifest.radar
    de = float(resolution_m) if resolution_m is not None else 0.25 * 299_792_458.0 / (2.0 * radar.bandwidth)
    src, tiles = rec.source(), []
    for u in apertures:
        a = rec.points.anchors[u]
        lo, hi = a[:, :2].min(axis=0) - TILE_MARGIN_M, a[:, :2].max(axis=0) + TILE_MARGIN_M
        d = np.array([4.0 * de, de])
        grow = np.sqrt(np.prod((hi - lo) / d) / MAX_TILE_PIXELS)
        if grow > 1.0:
            d = d * grow
        shape = tuple(int(n) for n in np.maximum(np.ceil((hi - lo) / d), 2))
        centre = 0.5 * (lo + hi)
        grid = GroundGrid.centered(centre[0], centre[1], d[0], shape, down=float(a[:, 2].mean()), spacing_east=d[1])
        ref = src.reference_pass(int(u))
        img = backproject(ref, grid, interpolation="linear")  # a picture: linear on the 4x range axis is ample
        tiles.append(ReferenceTile(int(u), grid.north, grid.east, np.abs(img.data)))
    return tiles


def update_status(update_time, pair_time, pair_code) -> list[str]:
    """Status of each update from its SAR pairs (updates.csv's ``time`` and ``status_code``): "fused" when one
    pair was fused, else "rejected" when one was rejected (code > 0), else "skipped" (every pair code -1), "none"
    when the update had no pair (altimeter only)."""
    pair_time, pair_code = np.asarray(pair_time, float), np.asarray(pair_code, int)
    out = []
    for t in np.asarray(update_time, float):
        codes = pair_code[np.abs(pair_time - t) <= 1e-6 * max(1.0, abs(t))]
        out.append("none" if codes.size == 0 else "fused" if np.any(codes == 0) else
                   "rejected" if np.any(codes > 0) else "skipped")
    return out


def _margins(left: float, bottom: float, top: float, hspace: float = 0.15, wspace: float = 0.2) -> dict:
    """Fixed subplot margins (a layout engine costs more than drawing these figures)."""
    return {"left": left, "right": 0.97, "bottom": bottom, "top": top, "hspace": hspace, "wspace": wspace}


def _draw_tiles(ax, tiles) -> None:
    peak = max((float(t.amplitude.max()) for t in tiles), default=0.0)
    for t in tiles:
        db = 20.0 * np.log10(np.maximum(t.amplitude / (peak if peak > 0 else 1.0), 1e-6))
        de, dn = (t.east[1] - t.east[0]) / 2, (t.north[1] - t.north[0]) / 2
        ax.imshow(db, extent=[t.east[0] - de, t.east[-1] + de, t.north[0] - dn, t.north[-1] + dn], origin="lower",
                  cmap="gray", vmin=-40.0, vmax=0.0, interpolation="nearest", zorder=0)


def _draw_points(ax, points, pair_status=None) -> None:
    """Anchors (crosses: where the reference product puts the points) and map positions (circles: where the
    navigator predicts them) of every aperture; a pair's map circle filled in its status colour."""
    if points is None:
        return
    anc, mp = points.anchors.reshape(-1, 3), points.map.reshape(-1, 3)
    ax.plot(anc[:, 1], anc[:, 0], "x", color="tab:orange", ms=5, label="reference points (anchor)", zorder=3)
    colours = "none" if pair_status is None else ["white" if s == "none" else STATUS_COLOURS[s] for s in pair_status]
    ax.scatter(mp[:, 1], mp[:, 0], s=22, facecolors=colours, edgecolors="k", linewidths=0.6,
               label="reference points (map)", zorder=4)


def _track_panel(ax, track: dict, updates: dict, status) -> None:
    ax.plot(track["east"], track["north"], "-", color="tab:purple", lw=1.2, label="estimated track", zorder=2)
    n = np.interp(updates["time"], track["time"], track["north"])
    e = np.interp(updates["time"], track["time"], track["east"])
    for s, colour in STATUS_COLOURS.items():
        m = np.array([x == s for x in status], dtype=bool)
        if m.any():
            label = f"update: {'altimeter only' if s == 'none' else s} ({int(m.sum())})"
            ax.scatter(e[m], n[m], s=28, color=colour, edgecolors="k", linewidths=0.5, label=label, zorder=5)


def track_figure(track: dict, updates: dict, points=None, tiles=(), pair_status=None) -> Figure:
    """Plan view (east right, north up, metres of the recording's local frame): the whole flight (the track, the
    update points coloured by status, the reference points, the outlines of the reference images), the track
    close up with its update points, and the reference images with their points (or the points alone when no
    image was formed; this panel only with ``points``).

    ``track``: ``time, north, east`` arrays (trajectory.nc/.csv); ``updates``: ``time`` of each update and the
    ``pair_time``, ``pair_code`` of updates.csv (:func:`update_status`); ``points``:
    ``recording.logs.ReferencePoints`` or None; ``tiles``: :class:`ReferenceTile`; ``pair_status`` one status
    per (aperture, point) in ``points``' order ("fused", "rejected", "skipped", "none": not processed; see
    STATUS_COLOURS) or None."""
    status = update_status(updates["time"], updates.get("pair_time", ()), updates.get("pair_code", ()))
    n = 3 if points is not None else 2
    fig = Figure(figsize=(5.0 * n, 5.6))
    axes = fig.subplots(1, n, squeeze=False, gridspec_kw=_margins(0.06, 0.09, 0.92, wspace=0.3))[0]
    _track_panel(axes[0], track, updates, status)
    _draw_points(axes[0], points, pair_status)
    for t in tiles:
        axes[0].add_patch(_outline(t))
    axes[0].set_title("flight and reference")
    _track_panel(axes[1], track, updates, status)
    axes[1].set_title("estimated track and updates")
    if points is not None:
        _draw_tiles(axes[2], tiles)
        _draw_points(axes[2], points, pair_status)
        for t in tiles:
            axes[2].add_patch(_outline(t))
        axes[2].set_title("reference pass amplitude (dB re peak)" if tiles else "reference points")
    for a in axes:
        a.set_aspect("equal", adjustable="datalim")
        a.set_xlabel("east [m]")
        a.set_ylabel("north [m]")
        a.grid(True, lw=0.3)
    axes[0].legend(loc="best", fontsize=7)
    return fig


def _outline(tile: ReferenceTile):
    from matplotlib.patches import Rectangle

    return Rectangle((tile.east[0], tile.north[0]), tile.east[-1] - tile.east[0], tile.north[-1] - tile.north[0],
                     fill=False, edgecolor="tab:cyan", lw=0.8, zorder=1)


def error_figure(errors: dict, names, title: str, unit: str, scale: float = 1.0) -> Figure:
    """One panel per state of ``names``: ``error_<name>`` of errors.csv (truth minus estimate) and ±3 x
    ``sigma_<name>``, times ``scale`` (SI to ``unit``), against ``time``."""
    t = errors["time"]
    fig = Figure(figsize=(8.0, 2.1 * len(names)))
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False, gridspec_kw=_margins(0.11, 0.08, 0.91))[:, 0]
    for ax, n in zip(axes, names):
        s3 = 3.0 * scale * errors[f"sigma_{n}"]
        ax.plot(t, scale * errors[f"error_{n}"], color="k", lw=1.0, label="truth − estimate")
        ax.plot(t, s3, "r", lw=1.2, label="±3σ (filter)")
        ax.plot(t, -s3, "r", lw=1.2)
        ax.set_ylabel(f"{n} [{unit}]")
        ax.grid(True, lw=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(title)
    return fig


def gnss_difference(track: dict, gnss) -> dict | None:
    """The estimate minus GNSS at the GNSS fixes inside the track's span: ``time``, ``difference`` (K, 3) NED [m],
    ``bound`` (K, 3) = 3 sqrt(sigma_est² + sigma_gnss²) (the estimate interpolated linearly); None when no fix lies
    in the span."""
    t = np.asarray(gnss.time, float)
    m = (t >= track["time"][0]) & (t <= track["time"][-1])
    if not m.any():
        return None
    est = np.stack([np.interp(t[m], track["time"], track[c]) for c in ("north", "east", "down")], -1)
    sig = np.stack([np.interp(t[m], track["time"], track[f"sigma_{c}"]) for c in ("north", "east", "down")], -1)
    return {"time": t[m], "difference": est - gnss.position[m],
            "bound": 3.0 * np.sqrt(sig ** 2 + gnss.position_sigma[m] ** 2)}


def gnss_figure(diff: dict, aided_until: float | None = None) -> Figure:
    """Estimate minus GNSS (``gnss_difference``) per NED axis against its ±3σ; a dashed line at ``aided_until``
    (the end of GNSS aiding, ``[initial] gnss_until_s``) when given."""
    fig = Figure(figsize=(8.0, 6.3))
    axes = fig.subplots(3, 1, sharex=True, gridspec_kw=_margins(0.11, 0.08, 0.91))
    for i, (ax, n) in enumerate(zip(axes, ("north", "east", "down"))):
        ax.plot(diff["time"], diff["difference"][:, i], ".-", color="k", lw=0.8, ms=3, label="estimate − GNSS")
        ax.plot(diff["time"], diff["bound"][:, i], "r", lw=1.2, label="±3√(σ_est² + σ_GNSS²)")
        ax.plot(diff["time"], -diff["bound"][:, i], "r", lw=1.2)
        if aided_until is not None:
            ax.axvline(aided_until, color="0.4", ls="--", lw=0.8)
        ax.set_ylabel(f"{n} [m]")
        ax.grid(True, lw=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle("Estimate minus GNSS position" + ("" if aided_until is None else
                                                   f" (GNSS-aided until {aided_until:g} s, dashed)"))
    return fig


def consistency_figure(nis: dict | None, nees: dict | None = None) -> Figure:
    """NEES per epoch (``nees``: ``time``, ``nees``, ``dof``) against chi2_band(dof, 1), and NIS per update
    (``nis``: ``time``, ``nis``, ``dof`` arrays) against chi2_band(dof_u, 1) of each update (a vertical bar);
    markers outside their band are red."""
    panels = [p for p in (("NEES", nees), ("NIS", nis)) if p[1] is not None]
    fig = Figure(figsize=(8.0, 2.8 * max(len(panels), 1)))
    axes = fig.subplots(max(len(panels), 1), 1, squeeze=False,
                        gridspec_kw=_margins(0.1, 0.1, 0.96, hspace=0.45))[:, 0]
    for ax, (name, d) in zip(axes, panels):
        t, v, dof = (np.asarray(d[k], float) for k in ("time", name.lower(), "dof"))
        lo, hi = chi2_band(np.broadcast_to(dof, t.shape), 1)
        inside = (v >= lo) & (v <= hi)
        if name == "NEES":
            ax.fill_between(t, lo, hi, color="tab:green", alpha=0.2, label="95 % band")
            ax.plot(t, v, color="k", lw=1.0, label="NEES")
        else:
            ax.vlines(t, lo, hi, color="tab:green", alpha=0.5, lw=4, label="95 % band")
            ax.plot(t[inside], v[inside], "o", color="k", ms=4, label="NIS")
        if np.any(~inside):
            ax.plot(t[~inside], v[~inside], "o", color="tab:red", ms=4, label="outside the band")
        ax.set_ylabel(name)
        ax.set_xlabel("time [s]")
        ax.grid(True, lw=0.3)
        ax.legend(loc="upper right", fontsize=8)
    return fig
