"""The layering of STYLE.md, kept true by walking the imports with ast.

cli -> pipeline -> stages (session I/O, calibrate, detect, fuse, compare, report, simulate)
-> filters -> core. A module imports only from its own component or a lower layer; stages
never import each other; only cli imports click; only session (I/O) and cli touch files.
"""

from __future__ import annotations

import ast
from pathlib import Path

PKG = Path(__file__).resolve().parents[1] / "armtrack_cli"
RANK = {"cli": 5, "pipeline": 4, "session": 3, "calibrate": 3, "detect": 3, "fuse": 3,
        "compare": 3, "report": 3, "simulate": 3, "measures": 2, "filters": 2, "vision": 2,
        "core": 1, "recipes": 1}
FILE_CALLS = {"open", "read_bytes", "write_bytes", "read_text", "write_text", "imread", "imwrite",
              "VideoCapture", "VideoWriter", "read_csv", "to_csv", "FileStorage", "savez",
              "savez_compressed", "mkstemp", "load", "exists", "is_file", "is_dir", "stat",
              "iterdir", "glob", "rglob", "listdir", "mkdir", "unlink", "rename", "replace"}
NOT_FILE_CALLS = {("replace", "dataclasses"), ("load", "json"), ("load", "tomllib")}


def _component(path: Path) -> str:
    rel = path.relative_to(PKG)
    return rel.parts[0].removesuffix(".py") if rel.parts[0] not in ("__init__.py", "__main__.py") \
        else "root"


def _modules():
    for path in sorted(PKG.rglob("*.py")):
        yield path, _component(path), ast.parse(path.read_text(), str(path))


def _imports(tree):
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name
        elif isinstance(node, ast.ImportFrom) and node.module:
            yield node.module


def test_every_component_has_a_layer():
    comps = {c for _, c, _ in _modules()} - {"root"}
    assert comps <= set(RANK), f"unranked components: {comps - set(RANK)}"


def test_imports_go_down_the_layers():
    bad = []
    for path, comp, tree in _modules():
        for mod in _imports(tree):
            if not mod.startswith("armtrack_cli."):
                continue
            target = mod.split(".")[1]
            if comp == "root" or target == comp:
                continue
            if RANK.get(target, 0) >= RANK.get(comp, 0):
                bad.append(f"{path.relative_to(PKG)} imports {mod}")
    assert not bad, "layering broken:\n" + "\n".join(bad)


def test_only_the_cli_imports_click():
    users = [str(p.relative_to(PKG)) for p, c, tree in _modules()
             if any(m.split(".")[0] == "click" for m in _imports(tree))]
    assert users and all(u.startswith("cli/") or u == "__main__.py" for u in users), users


def test_only_the_io_layer_touches_files():
    bad = []
    for path, comp, tree in _modules():
        if comp in ("session", "cli"):
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.Call):
                f = node.func
                # builtin open(), or file methods/functions reached by attribute (Path.write_text,
                # cv2.imread, np.savez…); our own I/O functions imported by name are the I/O layer
                name = f.id if isinstance(f, ast.Name) and f.id == "open" else f.attr if isinstance(
                    f, ast.Attribute) else None
                owner = f.value.id if isinstance(f, ast.Attribute) and isinstance(
                    f.value, ast.Name) else None
                if name == "replace" and not (isinstance(f, ast.Attribute) and owner == "os"):
                    continue  # str.replace, dataclasses.replace: not a file
                if name in FILE_CALLS and (name, owner) not in NOT_FILE_CALLS:
                    bad.append(f"{path.relative_to(PKG)}:{node.lineno} calls {name}")
    assert not bad, "file access outside the I/O layer:\n" + "\n".join(bad)


def test_the_pipeline_map_names_only_what_exists():
    """Every stage function and folder in pipeline/__init__.py's table exists."""
    import re

    from armtrack_cli import pipeline

    doc = pipeline.__doc__
    rows = re.findall(r"^ {4}(\w+)\((\w+)\)\s+(\S.*?)\s{2,}", doc, flags=re.M)
    assert len(rows) >= 6, rows
    for func, _, where in rows:
        assert callable(getattr(pipeline, func, None)), f"pipeline.{func} is in the map, not the code"
        for folder in re.findall(r"((?:\w+/)+)", where):
            assert (PKG / folder).is_dir(), f"{folder}/ is in the map, not the package"
    assert set(pipeline.STAGES) - {"report"} <= {f for f, _, _ in rows}
