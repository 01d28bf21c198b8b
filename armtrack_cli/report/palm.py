"""Palm sessions: the three wrist angles over time (Cordella et al., Fig. 4) with their range."""

from __future__ import annotations

import numpy as np

from armtrack_cli.report import layout, words
from armtrack_cli.report.data import SessionReport

COLS = (("flexion_deg", "wrist_flexion"), ("deviation_deg", "wrist_deviation"),
        ("pronation_deg", "wrist_pronation"))


def page(r: SessionReport):
    def draw(fig):
        d = r.trajectory
        if d is None or not all(c in d for c, _ in COLS):
            fig.text(0.5, 0.6, "no wrist-pose estimate in this work folder", ha="center",
                     fontsize=13, weight="bold")
            fig.text(0.5, 0.56, "The wrist angles need the palm-marker tracking; run it on this "
                     "session to see them here.", ha="center", fontsize=9.5)
            return
        t = d["t"].to_numpy()
        ax = fig.add_axes([0.11, 0.63, 0.82, 0.25])
        for (c, m), st in zip(COLS, layout.STYLES):
            ax.plot(t, d[c], **st, label=words.ANGLES[m])
        ax.set_ylabel("angle (°)")
        ax.set_xlabel("time (s)")
        ax.legend(loc="upper right")
        ax.set_title("The three wrist angles, relative to the neutral pose of the first second")
        for k, ((c, m), st) in enumerate(zip(COLS, layout.STYLES)):
            a = fig.add_axes([0.11, 0.42 - 0.16 * k, 0.82, 0.12])
            x = d[c].to_numpy(dtype=float)
            a.plot(t, x, **st)
            if np.isfinite(x).any():
                lo, hi = np.nanmin(x), np.nanmax(x)
                a.axhline(lo, **layout.LIMIT)
                a.axhline(hi, **layout.LIMIT)
                a.text(0.01, 0.92, f"range {words.with_unit(hi - lo, f'{m}_rom')} "
                       f"({words.with_unit(lo, f'{m}_min')} to {words.with_unit(hi, f'{m}_max')})",
                       transform=a.transAxes, va="top", fontsize=8.5,
                       bbox={"facecolor": "white", "edgecolor": "0.6", "linewidth": 0.5})
            a.set_ylabel(f"{m.split('_')[1]} (°)")
            if k == 2:
                a.set_xlabel("time (s)")

    return "Wrist angles", draw
