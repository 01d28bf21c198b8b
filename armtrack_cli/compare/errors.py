"""Estimate-versus-truth errors: time association with gaps kept missing, then per-axis and
3-D statistics in centimetres (the layout of Tao & Hu's Table I: mean/SD per axis)."""

from __future__ import annotations

import numpy as np

AXES = ("x", "y", "z", "3d")
COLUMNS = ("method", "joint", "axis", "mean_cm", "std_cm", "rmse_cm", "max_abs_cm",
           "within_5cm_pct", "n")


def truth_at(t: np.ndarray, t_truth: np.ndarray, xyz: np.ndarray, rate_hz: float) -> np.ndarray:
    """Linear interpolation of (M, 3) truth at times t. Where either neighbour is missing, or
    t is outside the truth or in a gap longer than 1.5 samples, the result is NaN."""
    i = np.searchsorted(t_truth, t, side="right")
    ok = (i > 0) & (i < t_truth.size)
    i0, i1 = np.clip(i - 1, 0, t_truth.size - 1), np.clip(i, 0, t_truth.size - 1)
    span = t_truth[i1] - t_truth[i0]
    ok &= span <= 1.5 / rate_hz
    f = np.where(span > 0, (t - t_truth[i0]) / np.where(span > 0, span, 1), 0.0)[:, None]
    # x0 (1 − f) + x1 f, computed in place in the gathered neighbours: two (n, 3) arrays
    # where the expression made five (the clock-offset search calls this hundreds of times
    # beside the scoring; issue 15), each element's arithmetic the same
    out, x1 = xyz[i0], xyz[i1]
    ok &= np.isfinite(out).all(axis=1) & np.isfinite(x1).all(axis=1)
    out *= 1 - f
    x1 *= f
    out += x1
    out[~ok] = np.nan
    return out


def error_rows(method: str, joint: str, est: np.ndarray, truth: np.ndarray) -> list[dict]:
    """Signed error est − truth, per axis and 3-D, over frames where both exist."""
    ok = np.isfinite(est).all(axis=1) & np.isfinite(truth).all(axis=1)
    e = (est[ok] - truth[ok]) * 100.0  # cm
    rows = []
    for k, axis in enumerate(AXES):
        v = e[:, k] if axis != "3d" else np.linalg.norm(e, axis=1)
        n = int(v.size)
        if n == 0:
            rows.append({"method": method, "joint": joint, "axis": axis, "mean_cm": np.nan,
                         "std_cm": np.nan, "rmse_cm": np.nan, "max_abs_cm": np.nan,
                         "within_5cm_pct": np.nan, "n": 0})
            continue
        rows.append({"method": method, "joint": joint, "axis": axis,
                     "mean_cm": float(v.mean()), "std_cm": float(v.std(ddof=1)) if n > 1 else 0.0,
                     "rmse_cm": float(np.sqrt(np.mean(v**2))), "max_abs_cm": float(np.abs(v).max()),
                     "within_5cm_pct": float(100.0 * np.mean(np.abs(v) <= 5.0)), "n": n})
    return rows


def table_one(rows: list[dict], joint: str = "wrist") -> str:
    """Tao & Hu's Table I: one row per method, 'mean/SD' of each axis error in cm."""
    methods = list(dict.fromkeys(r["method"] for r in rows if r["joint"] == joint))
    lines = [f"{joint} error (cm), mean/SD   {'X':>14} {'Y':>14} {'Z':>14} {'3-D RMSE':>9} "
             f"{'±5 cm %':>8}"]
    for m in methods:
        by = {r["axis"]: r for r in rows if r["method"] == m and r["joint"] == joint}
        cells = [f"{by[a]['mean_cm']:.2f}/{by[a]['std_cm']:.2f}" for a in ("x", "y", "z")]
        worst = min(by[a]["within_5cm_pct"] for a in ("x", "y", "z"))
        lines.append(f"{m:<29} {cells[0]:>14} {cells[1]:>14} {cells[2]:>14} "
                     f"{by['3d']['rmse_cm']:>9.2f} {worst:>8.1f}")
    return "\n".join(lines)


def pooled(rows: list[dict]) -> list[dict]:
    """Rows of several sessions combined per (method, joint, axis) exactly as if computed over
    all their frames at once: pooled mean, SD (ddof = 1) from the within- and between-session
    sums of squares, RMSE from the summed squares, max and share within ±5 cm by count."""
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r["method"], r["joint"], r["axis"]), []).append(r)
    out = []
    for (method, joint, axis), rs in groups.items():
        rs = [r for r in rs if r["n"] > 0]
        n = sum(r["n"] for r in rs)
        if n == 0:
            out.append({"method": method, "joint": joint, "axis": axis, "mean_cm": np.nan,
                        "std_cm": np.nan, "rmse_cm": np.nan, "max_abs_cm": np.nan,
                        "within_5cm_pct": np.nan, "n": 0})
            continue
        mean = sum(r["n"] * r["mean_cm"] for r in rs) / n
        ss = sum((r["n"] - 1) * r["std_cm"] ** 2 + r["n"] * (r["mean_cm"] - mean) ** 2 for r in rs)
        out.append({"method": method, "joint": joint, "axis": axis, "mean_cm": mean,
                    "std_cm": float(np.sqrt(ss / (n - 1))) if n > 1 else 0.0,
                    "rmse_cm": float(np.sqrt(sum(r["n"] * r["rmse_cm"] ** 2 for r in rs) / n)),
                    "max_abs_cm": max(r["max_abs_cm"] for r in rs),
                    "within_5cm_pct": sum(r["n"] * r["within_5cm_pct"] for r in rs) / n, "n": n})
    return out


def accuracy_3d(rows) -> dict[str, dict[str, dict]]:
    """{method: {joint: {rmse_cm, within_5cm_pct, n}}} of the 3-D rows of errors.csv, for
    `compare --json`: a script reads the accuracy without parsing the CSV; a statistic over no
    frame (n = 0) is null, never NaN (which is no JSON)."""
    out: dict[str, dict[str, dict]] = {}
    for r in rows:
        if r["axis"] == "3d":
            out.setdefault(r["method"], {})[r["joint"]] = {
                "rmse_cm": _json_number(r["rmse_cm"]),
                "within_5cm_pct": _json_number(r["within_5cm_pct"]), "n": int(r["n"])}
    return out


def _json_number(x) -> float | None:
    x = float(x)
    return round(x, 4) if np.isfinite(x) else None
