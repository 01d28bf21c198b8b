"""Trajectory pages: wrist x, y, z with the uncertainty band (Tao & Hu 2008, Fig. 6), top and
side views of the path (their Fig. 8), the elbow angle and the hand speed with its units."""

from __future__ import annotations

import numpy as np

from armtrack_cli.measures import Settings, angles, path, smoothness
from armtrack_cli.measures.base import DEFAULT, NotComputable
from armtrack_cli.measures.signal import speed_profile
from armtrack_cli.report import layout, words
from armtrack_cli.report.data import SessionReport

XYZ = ("x", "y", "z")


def _xyz(df, prefix: str) -> np.ndarray | None:
    cols = [f"{prefix}_{a}" for a in XYZ]
    return df[cols].to_numpy(dtype=float) if all(c in df for c in cols) else None


def _est_label(r: SessionReport) -> str:
    return f"estimate ({words.method_name(r.method)})"


def position_page(r: SessionReport):
    def draw(fig):
        d = r.trajectory
        t, w, sd = d["t"].to_numpy(), _xyz(d, "wrist"), _xyz(d, "wrist")
        sd = d[[f"wrist_{a}_sd" for a in XYZ]].to_numpy() if "wrist_x_sd" in d else None
        for k, a in enumerate(XYZ):
            ax = fig.add_axes([0.11, 0.62 - 0.265 * k, 0.82, 0.2])
            if sd is not None:
                ax.fill_between(t, w[:, k] - 2 * sd[:, k], w[:, k] + 2 * sd[:, k], **layout.BAND,
                                label="uncertainty band (± 2 SD, 95 %)")
            ax.plot(t, w[:, k], **layout.ESTIMATE, label=_est_label(r))
            if r.truth_wrist is not None:
                ax.plot(t, r.truth_wrist[:, k], **layout.TRUTH, label="reference motion capture")
            ax.set_ylabel(f"wrist {a} (m)")
            if k == 2:
                ax.set_xlabel("time (s)")
            if k == 0:
                ax.legend(loc="lower left", bbox_to_anchor=(0, 1.02), ncol=2, frameon=False)
        fig.text(0.07, 0.905, "Position of the wrist in the table's frame (x, y along the table, "
                 "z up).", fontsize=9)

    return "Wrist position over time", draw


def views_page(r: SessionReport):
    def draw(fig):
        d = r.trajectory
        w = _xyz(d, "wrist")
        for k, (i, j, title) in enumerate(((0, 1, "seen from above (top view)"),
                                           (0, 2, "seen from the side (side view)"))):
            ax = fig.add_axes([0.14, 0.52 - 0.42 * k, 0.74, 0.34])
            ax.plot(w[:, i], w[:, j], **layout.ESTIMATE, label=_est_label(r))
            if r.truth_wrist is not None:
                ax.plot(r.truth_wrist[:, i], r.truth_wrist[:, j], **layout.TRUTH,
                        label="reference motion capture")
            ok = np.flatnonzero(np.isfinite(w).all(axis=1))
            if ok.size:
                ax.plot(*w[ok[0], [i, j]], "o", color="black", markerfacecolor="white",
                        label="start")
            ax.set_aspect("equal", adjustable="datalim")
            ax.set_xlabel(f"{XYZ[i]} (m)")
            ax.set_ylabel(f"{XYZ[j]} (m)")
            ax.set_title(f"Wrist path {title}")
            if k == 1:
                ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3, frameon=False)

    return "Path of the wrist", draw


def speed_and_units(r: SessionReport, s: Settings = DEFAULT):
    """(t, speed, indices of the movement-unit peaks, threshold) as the measures count them."""
    d = r.trajectory
    t, _, v = speed_profile(d["t"].to_numpy(), _xyz(d, "wrist"), s)
    a, b = path.onset_offset(v, s)
    _, pk = smoothness.movement_units(t[a:b + 1], v[a:b + 1], s)
    return t, v, pk + a, s.onset_fraction * v.max()


def motion_page(r: SessionReport):
    def draw(fig):
        d = r.trajectory
        top = 0.52
        w, e = _xyz(d, "wrist"), _xyz(d, "elbow")
        if e is not None and r.shoulder is not None:
            ax = fig.add_axes([0.11, 0.55, 0.82, 0.32])
            sh = np.broadcast_to(r.shoulder, e.shape)
            ang = angles.elbow_flexion_deg(sh, e, w)
            ax.plot(d["t"], ang, **layout.ESTIMATE, label="elbow flexion (0° = straight arm)")
            if np.isfinite(ang).any():
                lo, hi = np.nanmin(ang), np.nanmax(ang)
                ax.axhline(lo, **layout.LIMIT,
                           label=f"range of motion {words.with_unit(hi - lo, 'elbow_flexion_rom')}")
                ax.axhline(hi, **layout.LIMIT)
            ax.set_ylabel("elbow flexion (°)")
            ax.set_xlabel("time (s)")
            ax.legend(loc="lower left", bbox_to_anchor=(0, 1.02), ncol=2, frameon=False)
            top = 0.10
        ax = fig.add_axes([0.11, top, 0.82, 0.33])
        try:
            t, v, pk, th = speed_and_units(r)
        except NotComputable as exc:
            ax.text(0.5, 0.5, f"hand speed not computable: {exc}", ha="center",
                    transform=ax.transAxes)
            return
        ax.plot(t, v, **layout.ESTIMATE, label="hand speed")
        ax.plot(t[pk], v[pk], "v", color="black", markersize=7,
                label=f"movement units ({pk.size}): peaks rising > 20 mm/s")
        ax.axhline(th, **layout.LIMIT, label="onset / offset threshold (2 % of peak)")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("speed (m/s)")
        ax.set_ylim(0, 1.12 * float(np.nanmax(v)))
        ax.legend(loc="lower left", bbox_to_anchor=(0, 1.02), ncol=2, frameon=False)

    return ("Elbow angle and hand speed" if r.shoulder is not None and "elbow_x" in r.trajectory
            else "Hand speed"), draw


def pages(r: SessionReport) -> list:
    return [position_page(r), views_page(r), motion_page(r)]
