"""Plain names, units and number formats: one rule shared by every page (and the tests)."""

from __future__ import annotations

import math

METHODS = {  # short plain names for tables; page 1 adds the source
    "inertial": "inertial sensor only",
    "ekf": "extended Kalman filter",
    "ukf": "unscented Kalman filter",
    "pf": "particle filter",
    "pf-constraint": "particle filter with arm constraint",
    "arm-smoother": "orientation-aware arm smoother",
    "ukf-palm": "palm-marker Kalman filter",
}
SOURCES = {"pf-constraint": "Tao & Hu 2008", "ekf": "Tao & Hu 2008", "pf": "Tao & Hu 2008",
           "inertial": "Tao & Hu 2008", "ukf-palm": "Cordella et al.",
           "arm-smoother": "armtrack, after Tao & Hu 2008"}
TASKS = {"circle": "circles on the table", "rectangle": "rectangles on the table",
         "reach": "reaching forward and back", "figure8": "figures of eight on the table",
         "wrist-rom": "wrist range of motion", "reach-grasp": "reach and grasp",
         "wrist-deviation": "wrist radial and ulnar deviation",
         "wrist-flexion": "wrist flexion and extension"}

# measure: (plain name, display unit, decimals); values are shown in the CSV's own unit
MEASURES = {
    "wrist_peak_speed": ("peak hand speed", "m/s", 3),
    "wrist_mean_speed": ("mean hand speed while moving", "m/s", 3),
    "time_to_peak_speed": ("time to peak speed", "s", 2),
    "movement_time": ("movement time", "s", 2),
    "wrist_path_length": ("hand path length", "m", 3),
    "movement_units": ("movement units", "", 0),
    "sparc": ("smoothness, SPARC", "", 2),
    "ldlj": ("smoothness, log dimensionless jerk", "", 2),
    "straightness": ("path / straight distance", "", 2),
    "segments": ("movements found", "", 0),
}
ANGLES = {  # the convention in words, for page 1
    "elbow_flexion": "elbow flexion (0° = straight arm)",
    "shoulder_elevation": "shoulder elevation (0° = arm hanging down)",
    "shoulder_plane": "plane of elevation (0° = out to the side, 90° = forward)",
    "forearm_pronation": "forearm rotation (+ pronation, palm down; − supination)",
    "wrist_flexion": "wrist flexion (+ towards the palm; − extension)",
    "wrist_deviation": "wrist deviation (+ radial, thumb side; − ulnar)",
    "wrist_pronation": "hand pronation (+ palm down; − supination)",
}
SHORT = {"elbow_flexion": "elbow flexion", "shoulder_elevation": "shoulder elevation",
         "shoulder_plane": "plane of elevation", "forearm_pronation": "forearm pronation",
         "wrist_flexion": "wrist flexion", "wrist_deviation": "wrist deviation",
         "wrist_pronation": "hand pronation"}
PARTS = {"rom": "range", "rom_p5_p95": "range 5th-95th pct", "min": "least", "max": "most"}
for _a, _w in SHORT.items():
    for _k, _p in PARTS.items():
        MEASURES[f"{_a}_{_k}"] = (f"{_w}: {_p}", "°", 1)
for _a in ("wrist_flexion", "wrist_deviation", "wrist_pronation"):  # core/wrist_measures.py
    MEASURES[f"{_a}_peak_speed"] = (f"{SHORT[_a]}: peak angular speed", "°/s", 1)
    MEASURES[f"{_a}_mean_speed"] = (f"{SHORT[_a]}: mean angular speed", "°/s", 1)


def name(measure: str) -> str:
    return MEASURES.get(measure, (measure.replace("_", " "), "", 3))[0]


def _finite(value) -> float | None:
    """value as a float, or None where it is no finite number (a CSV's reason, NaN, inf)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def number(value, measure: str) -> str:
    """The value as the report prints it (no unit): the measure's decimals, "−" for minus."""
    v = _finite(value)
    if v is None:
        return "not computable"
    d = MEASURES.get(measure, ("", "", 3))[2]
    return f"{v:.{d}f}".replace("-", "−")


def sd_number(sd, measure: str) -> str:
    """An SD as printed: the measure's decimals, one at least, and one significant digit at
    least (a count's SD of 0.36 units is no "± 0", a speed's of 0.0003 m/s no "± 0.000":
    either would say the value is certain)."""
    v = _finite(sd)
    if v is None:
        return "not computable"
    d = max(MEASURES.get(measure, ("", "", 3))[2], 1)
    while 0 < abs(v) < 0.5 * 10.0 ** -d and d < 6:  # one significant digit at least
        d += 1
    return f"{v:.{d}f}".replace("-", "−")


def sd_with_unit(sd, measure: str) -> str:
    return _with_unit(sd_number(sd, measure), measure)


def with_unit(value, measure: str) -> str:
    return _with_unit(number(value, measure), measure)


def _with_unit(s: str, measure: str) -> str:
    """A printed number with the measure's unit ("°" joined, others after a space)."""
    unit = MEASURES.get(measure, ("", "", 3))[1]
    if s == "not computable" or not unit:
        return s
    return s + unit if unit == "°" else f"{s} {unit}"


def clip(text: str, n: int) -> str:
    """text cut to n characters with "…" (a name in a header that must leave room for the
    page number); unchanged when it fits."""
    return text if len(text) <= n else text[:n - 1].rstrip() + "…"


def lines_of(text: str, n: int) -> list[str]:
    """text broken into lines of at most n characters, at spaces where it has them."""
    import textwrap

    return textwrap.wrap(text, n, break_long_words=True, break_on_hyphens=False) or [""]


def method_name(method: str | None, *, source: bool = False) -> str:
    if method is None:
        return "no estimate"
    name = METHODS.get(method, method)
    return f"{name} ({SOURCES[method]})" if source and method in SOURCES else name


def task_name(task: str) -> str:
    return TASKS.get(task, task or "not stated")
