"""Recipes: TOML files of detector and filter settings (recipes/NAME.toml, or a path).

Settings resolve as dataclass defaults < recipe < ``--set key=value``. An unknown key or a
misspelt section is an error that lists the valid ones; the resolved settings are written
beside every output.
"""

from __future__ import annotations

import dataclasses
import difflib
import sys
from pathlib import Path
from typing import Any

from armtrack_cli.core.errors import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

RECIPE_DIRS = (Path.cwd() / "recipes", Path(__file__).resolve().parents[2] / "recipes")


def recipe_names() -> list[str]:
    return sorted({p.stem for d in RECIPE_DIRS if d.is_dir() for p in d.glob("*.toml")})


def load_recipe(recipe: str | None) -> tuple[dict[str, Any], str]:
    """(nested dict, where it came from) for a recipe name or path; ({}, "defaults") for None."""
    if recipe is None:
        return {}, "defaults"
    path = Path(recipe)
    if not path.is_file():
        found = [d / f"{recipe}.toml" for d in RECIPE_DIRS if (d / f"{recipe}.toml").is_file()]
        if not found:
            close = difflib.get_close_matches(recipe, recipe_names(), n=1)
            raise ConfigError(recipe, "is neither a recipe file nor a recipe name",
                              f"did you mean {close[0]!r}?" if close else
                              f"recipes are {', '.join(recipe_names()) or 'none'}")
        path = found[0]
    try:
        return tomllib.loads(path.read_text()), str(path)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(path, f"is not valid TOML: {exc}") from None


def apply_overrides(doc: dict[str, Any], sets: tuple[str, ...]) -> dict[str, Any]:
    """``--set a.b.c=value``: the value is read as TOML (numbers, strings, booleans, lists)."""
    import copy

    doc = copy.deepcopy(doc)
    for item in sets:
        if "=" not in item:
            raise ConfigError("--set", f"{item!r} is not KEY=VALUE", "e.g. --set fuse.particles=1000")
        key, raw = item.split("=", 1)
        try:
            value = tomllib.loads(f"v = {raw}")["v"]
        except tomllib.TOMLDecodeError:
            value = raw  # a bare word is a string
        node = doc
        parts = key.strip().split(".")
        for p in parts[:-1]:
            node = node.setdefault(p, {})
        node[parts[-1]] = value
    return doc


def section(doc: dict[str, Any], path: str, cls: type, where: str):
    """Build the frozen dataclass ``cls`` from doc[path] (dotted), checking every key."""
    node: Any = doc
    for p in path.split("."):
        node = node.get(p, {}) if isinstance(node, dict) else {}
    if not isinstance(node, dict):
        raise ConfigError(where, f"[{path}] is not a table")
    valid = {f.name: f for f in dataclasses.fields(cls)}
    for k in node:
        if k not in valid:
            close = difflib.get_close_matches(k, list(valid), n=1)
            raise ConfigError(where, f"[{path}] {k} is not a setting",
                              f"did you mean {close[0]!r}?" if close else
                              f"settings are {', '.join(valid)}")
    kwargs = {}
    for k, v in node.items():
        default = getattr(cls(), k)
        if isinstance(default, (int, float)) and not isinstance(default, bool):
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise ConfigError(where, f"[{path}] {k} = {v!r} is not a number")
            v = type(default)(v) if not (isinstance(default, int) and not float(v).is_integer()) \
                else v
        elif isinstance(default, str) and not isinstance(v, str):
            raise ConfigError(where, f"[{path}] {k} = {v!r} is not a string")
        kwargs[k] = v
    return cls(**kwargs)


def known_sections(doc: dict[str, Any], sections: tuple[str, ...], where: str) -> None:
    """Refuse a recipe section nobody reads (a misspelt [detect.pach])."""
    def walk(node, prefix):
        for k, v in node.items():
            name = f"{prefix}{k}"
            if isinstance(v, dict):
                if name not in sections and not any(s.startswith(name + ".") for s in sections):
                    close = difflib.get_close_matches(name, sections, n=1)
                    raise ConfigError(where, f"[{name}] is not a recipe section",
                                      f"did you mean [{close[0]}]?" if close else
                                      f"sections are {', '.join(sections)}")
                if name not in sections:
                    walk(v, name + ".")
    walk(doc, "")
