"""Walk a ROS 2 message definition (MCAP ``ros2msg`` schema text) for fields of a given type.

Drivers often wrap the standard messages in their own (VectorNav's
``custom_interfaces/msg/Vectornav``: ``header``, ``imu`` (sensor_msgs/Imu), ``mag_field``
(sensor_msgs/MagneticField), ``raw``). The schema text holds the top-level definition, then
one ``MSG: pkg/Type`` section per nested type after a line of ``=``; a field's type may be
written ``pkg/Type``, ``pkg/msg/Type`` or, inside the same package, ``Type``.
"""

from __future__ import annotations

import re

_BUILTIN = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
            "int32", "uint32", "int64", "uint64", "string", "wstring", "time", "duration"}
_SEP = re.compile(r"^={3,}\s*$")


def _norm(name: str) -> str:
    """'sensor_msgs/msg/Imu' and 'sensor_msgs/Imu' -> 'sensor_msgs/Imu'."""
    parts = name.strip().split("/")
    return f"{parts[0]}/{parts[-1]}" if len(parts) >= 2 else name.strip()


def parse_definitions(root_name: str, text: str) -> dict[str, list[tuple[str, str]]]:
    """{normalised type: [(field type, field name)]}; the first block is ``root_name``'s."""
    defs: dict[str, list[tuple[str, str]]] = {}
    current = _norm(root_name)
    defs[current] = []
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        if _SEP.match(line):
            current = None
            continue
        if line.startswith("MSG:"):
            current = _norm(line[4:])
            defs[current] = []
            continue
        parts = line.split()
        if current is None or len(parts) < 2 or "=" in parts[1]:  # constants: TYPE NAME=value
            continue
        defs[current].append((re.sub(r"\[.*\]$", "", parts[0]), parts[1]))
    return defs


def _resolve(ftype: str, package: str) -> str | None:
    if ftype in _BUILTIN or ftype.startswith(("string<", "wstring<")):
        return None
    if ftype == "Header":
        return "std_msgs/Header"
    return _norm(ftype) if "/" in ftype else f"{package}/{ftype}"


def field_paths(root_name: str, text: str, wanted: str, *, max_depth: int = 6) -> list[str]:
    """Dotted paths to every field of type ``wanted`` (e.g. 'sensor_msgs/Imu'); '' when the
    root message itself is of that type. Breadth first, so the shallowest come first."""
    wanted, root = _norm(wanted), _norm(root_name)
    if root == wanted:
        return [""]
    defs = parse_definitions(root_name, text)
    out: list[str] = []
    queue: list[tuple[str, str, int]] = [(root, "", 0)]
    while queue:
        typ, prefix, depth = queue.pop(0)
        package = typ.split("/")[0]
        for ftype, fname in defs.get(typ, []):
            full = _resolve(ftype, package)
            if full is None:
                continue
            path = f"{prefix}.{fname}" if prefix else fname
            if full == wanted:
                out.append(path)
            elif depth < max_depth and full in defs:
                queue.append((full, path, depth + 1))
    return out


def get_path(msg, path: str):
    """The nested field of a decoded message (object attributes or dict keys) at ``path``."""
    for name in filter(None, path.split(".")):
        msg = msg[name] if isinstance(msg, dict) else getattr(msg, name)
    return msg
