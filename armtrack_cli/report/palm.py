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
        guessed = d["predicted_only"].to_numpy() == 1 if "predicted_only" in d else \
            np.zeros(t.size, bool)  # the filter's prediction while the markers were lost
        ax = fig.add_axes([0.11, 0.63, 0.82, 0.25])
        for (c, m), st in zip(COLS, layout.STYLES):
            ax.plot(t, np.where(guessed, np.nan, d[c]), **st, label=words.ANGLES[m])
        ax.set_ylabel("angle (°)")
        ax.set_xlabel("time (s)")
        ax.legend(loc="upper right")
        ax.set_title("The three wrist angles, relative to the neutral pose of the first second")
        if guessed.any():
            fig.text(0.11, 0.567, f"Left empty: {guessed.sum()} frames ({guessed.sum() / t.size:.0%}) "
                     "where no palm marker was seen (the tracking only predicted them); the "
                     "ranges leave them out.", fontsize=8.5)
        for k, ((c, m), st) in enumerate(zip(COLS, layout.STYLES)):
            a = fig.add_axes([0.11, 0.42 - 0.16 * k, 0.82, 0.12])
            x = np.where(guessed, np.nan, d[c].to_numpy(dtype=float))
            a.plot(t, x, **st)
            if np.isfinite(x).any():
                lo, hi = np.nanmin(x), np.nanmax(x)
                a.axhline(lo, **layout.LIMIT)
                a.axhline(hi, **layout.LIMIT)
                a.text(0.01, 0.92, f"range {words.with_unit(hi - lo, f'{m}_rom')} "
                       f"({words.with_unit(lo, f'{m}_min')} to {words.with_unit(hi, f'{m}_max')})",
                       transform=a.transAxes, va="top", fontsize=8.5,
                       bbox={"facecolor": "white", "edgecolor": "0.6", "linewidth": 0.5})
                mid = (lo + hi) / 2  # 10° tall at least: 1° of noise must not fill it
                a.set_ylim(min(lo, mid - 5) - 1, max(hi, mid + 5) + 1)
            a.set_ylabel(f"{m.split('_')[1]} (°)")
            if k == 2:
                a.set_xlabel("time (s)")

    return "Wrist angles", draw
