"""Two session folders (or truth files) equal within cross-machine tolerances.

armtrack promises byte-identical outputs for the same inputs, seed, machine and library
versions, and equal values up to floating-point round-off elsewhere: numpy's vectorised
transcendental functions take different code paths on different CPUs, so float64 results
differ in their last bits (seen between two machines of our CI's kind: positions 3.6e-16 m,
orientations 5e-16, accelerations by finite differences 9.3e-10 m/s²).

The tolerances, per kind of file, and why:

- float arrays (truth .npz, MCAP payloads): |a − b| ≤ 1e-8 · max(1, max|b|). The largest
  difference seen is 9.3e-10 on accelerations of ~10 m/s² (a second finite difference
  amplifies 1e-16 by 1/h² ≈ 1e6); 1e-8 of the array's scale leaves a 100× margin while
  any real change of the simulator (a millimetre, a microsecond) is 1e5× larger.
- integer and boolean arrays: equal (they are counts, indices and decisions);
- text (session.toml, Xsens, Qualisys, YAML): equal outside numbers; each number within
  one unit of its last printed decimal (round-off can move a value across a rounding
  boundary and flip that digit, nothing more);
- 16-bit depth PNGs: depth in whole millimetres, within 1 mm (the same rounding flip);
- video: same frame count and size, each decoded frame within 1 grey level on average
  (a changed pixel value can change the encoder's choices nearby).

``differences(a, b)`` returns one line per file or array that differs beyond these, naming
it and by how much; an empty list means equal.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

FLOAT_REL = 1e-8
VIDEO_MEAN_GREY = 1.0
DEPTH_MM = 1
_NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


def float_tolerance(reference: np.ndarray) -> float:
    finite = np.abs(reference[np.isfinite(reference)])
    return FLOAT_REL * max(1.0, float(finite.max()) if finite.size else 1.0)


def arrays(name: str, a: np.ndarray, b: np.ndarray) -> list[str]:
    """``a`` (made here) against ``b`` (the reference)."""
    if a.shape != b.shape or a.dtype != b.dtype:
        return [f"{name}: shape/dtype {a.shape} {a.dtype} against {b.shape} {b.dtype}"]
    if not np.issubdtype(a.dtype, np.floating):
        n = int(np.sum(a != b))
        return [f"{name}: {n} of {a.size} values differ"] if n else []
    if not np.array_equal(np.isnan(a), np.isnan(b)):
        return [f"{name}: missing (NaN) in different places"]
    ok = np.isfinite(b)
    if not np.array_equal(a[~ok], b[~ok], equal_nan=True):
        return [f"{name}: infinities differ"]
    diff = float(np.max(np.abs(a[ok] - b[ok]), initial=0.0))
    tol = float_tolerance(b)
    return [f"{name}: max difference {diff:.3g} > {tol:.3g}"] if diff > tol else []


def npz(path: Path, ref: Path) -> list[str]:
    with np.load(path) as a, np.load(ref) as b:
        if sorted(a.files) != sorted(b.files):
            return [f"{path.name}: arrays {sorted(a.files)} against {sorted(b.files)}"]
        return [line for k in sorted(a.files) for line in arrays(f"{path.name}[{k}]", a[k], b[k])]


def text(path: Path, ref: Path) -> list[str]:
    a, b = path.read_text(), ref.read_text()
    if _NUMBER.sub("#", a) != _NUMBER.sub("#", b):
        la, lb = a.splitlines(), b.splitlines()
        k = next((i for i, (x, y) in enumerate(zip(la, lb))
                  if _NUMBER.sub("#", x) != _NUMBER.sub("#", y)), min(len(la), len(lb)))
        return [f"{path.name}: text differs at line {k + 1}"]
    worst, where = 0.0, None
    for k, (x, y) in enumerate(zip(_NUMBER.findall(a), _NUMBER.findall(b))):
        unit = 10.0 ** -len(y.split(".")[1].split("e")[0].split("E")[0]) if "." in y else 1.0
        excess = abs(float(x) - float(y)) - unit * (1 + 1e-9)
        if excess > worst:
            worst, where = excess, (k, x, y)
    return [f"{path.name}: number #{where[0]} is {where[1]}, reference {where[2]}"] if where else []


def depth_png(path: Path, ref: Path) -> list[str]:
    import cv2

    a = cv2.imread(str(path), cv2.IMREAD_UNCHANGED).astype(np.int64)
    b = cv2.imread(str(ref), cv2.IMREAD_UNCHANGED).astype(np.int64)
    if a.shape != b.shape:
        return [f"{path}: {a.shape} against {b.shape}"]
    diff = int(np.abs(a - b).max())
    return [f"{path}: depth differs by {diff} mm > {DEPTH_MM}"] if diff > DEPTH_MM else []


def video(path: Path, ref: Path) -> list[str]:
    import cv2

    ca, cb = cv2.VideoCapture(str(path)), cv2.VideoCapture(str(ref))
    worst, k, out = 0.0, 0, []
    try:
        while True:
            ra, fa = ca.read()
            rb, fb = cb.read()
            if ra != rb:
                return [f"{path.name}: {k} frames against more or fewer in the reference"]
            if not ra:
                break
            if fa.shape != fb.shape:
                return [f"{path.name}: frame {k} is {fa.shape}, reference {fb.shape}"]
            worst = max(worst, float(np.mean(np.abs(fa.astype(np.int16) - fb.astype(np.int16)))))
            k += 1
    finally:
        ca.release()
        cb.release()
    if worst > VIDEO_MEAN_GREY:
        out.append(f"{path.name}: a frame differs by {worst:.2f} grey levels on average "
                   f"> {VIDEO_MEAN_GREY}")
    return out


def _fields(obj, prefix: str) -> dict[str, object]:
    """A decoded message as flat {path: value}."""
    if isinstance(obj, (bytes, bytearray, str, int, float, bool)) or obj is None:
        return {prefix: obj}
    if isinstance(obj, (list, tuple)):
        return {k: v for i, x in enumerate(obj) for k, v in _fields(x, f"{prefix}[{i}]").items()}
    if isinstance(obj, dict):
        items = obj.items()
    else:
        names = getattr(obj, "__slots__", None) or list(vars(obj))
        items = ((n, getattr(obj, n)) for n in names)
    return {k: v for n, x in items for k, v in _fields(x, f"{prefix}.{n}").items()}


def _mcap_messages(path: Path) -> tuple[list, dict[str, list[float]], list]:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    keys, floats, other = [], {}, []
    with path.open("rb") as f:
        for schema, channel, message, decoded in make_reader(
                f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            keys.append((channel.topic, schema.name if schema else None, message.log_time))
            for k, v in _fields(decoded, channel.topic).items():
                if isinstance(v, float):
                    floats.setdefault(_strip_index(k), []).append(v)
                else:
                    other.append((k, v))
    return keys, floats, other


def _strip_index(key: str) -> str:
    return re.sub(r"\[\d+\]", "[]", key)


def mcap(path: Path, ref: Path) -> list[str]:
    ka, fa, oa = _mcap_messages(path)
    kb, fb, ob = _mcap_messages(ref)
    if ka != kb:
        return [f"{path.name}: topics, schemas or log times differ"]
    if oa != ob or sorted(fa) != sorted(fb):
        return [f"{path.name}: non-float fields differ"]
    return [line for k in sorted(fa)
            for line in arrays(f"{path.name}[{k}]", np.array(fa[k]), np.array(fb[k]))]


def differences(made: Path, reference: Path) -> list[str]:
    """Every file below ``made`` against the same relative path below ``reference``."""
    out = []
    files = sorted(p.relative_to(made) for p in made.rglob("*") if p.is_file())
    ref_files = sorted(p.relative_to(reference) for p in reference.rglob("*") if p.is_file())
    if files != ref_files:
        out.append(f"files differ: {sorted(set(files) ^ set(ref_files))}")
    for rel in files:
        a, b = made / rel, reference / rel
        if not b.is_file() or a.read_bytes() == b.read_bytes():
            continue
        out += compare_file(a, b)
    return out


def compare_file(a: Path, b: Path) -> list[str]:
    suffix = a.suffix.lower()
    if suffix == ".npz":
        return npz(a, b)
    if suffix == ".mcap":
        return mcap(a, b)
    if suffix in (".mp4", ".avi", ".mkv"):
        return video(a, b)
    if suffix == ".png":
        return depth_png(a, b)
    return text(a, b)
