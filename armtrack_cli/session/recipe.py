"""Recipes: TOML files of detector and filter settings (a path, or a recipe's name).

A name is looked up in ./recipes/, then in each folder of $ARMTRACK_RECIPES (a user's or
lab's own recipes, separated by the path separator), then among the recipes shipped inside
the package (armtrack_cli/recipes, package data, so an installed armtrack finds them from any
folder).

Settings resolve as dataclass defaults < recipe < ``--set key=value``. An unknown key or a
misspelt section is an error that lists the valid ones; the resolved settings are written
beside every output.
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
from importlib import resources
from pathlib import Path
from typing import Any

from armtrack_cli.core import limits
from armtrack_cli.core.errors import ConfigError, did_you_mean
from armtrack_cli.session.files import read_small_text

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ENV_VAR = "ARMTRACK_RECIPES"


def recipe_dirs() -> list[Path]:
    """Where names are looked up, first match wins."""
    user = [Path(p) for p in os.environ.get(ENV_VAR, "").split(os.pathsep) if p]
    return [Path.cwd() / "recipes", *user, bundled_dir()]


def bundled_dir() -> Path:
    return Path(str(resources.files("armtrack_cli.recipes")))


def recipe_names() -> list[str]:
    return sorted({p.stem for d in recipe_dirs() if d.is_dir() for p in d.glob("*.toml")})


def recipe_file(recipe: str | None) -> Path | None:
    """The file a recipe name or path resolves to (None for none, or one not found)."""
    if recipe is None:
        return None
    if Path(recipe).exists() or Path(recipe).is_symlink():
        return Path(recipe)  # a path: read_small_text says what is wrong with it
    return next((d / f"{recipe}.toml" for d in recipe_dirs() if (d / f"{recipe}.toml").is_file()),
                None)


def load_recipe(recipe: str | None) -> tuple[dict[str, Any], str]:
    """(nested dict, where it came from) for a recipe name or path; ({}, "defaults") for None."""
    if recipe is None:
        return {}, "defaults"
    path = recipe_file(recipe)
    if path is None:
        raise ConfigError(recipe, "is neither a recipe file nor a recipe name",
                          did_you_mean(recipe, recipe_names(), what="recipes"))
    try:
        return tomllib.loads(read_small_text(path, ConfigError, "a recipe (TOML)")), str(path)
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
            raise ConfigError(where, f"[{path}] {k} is not a setting",
                              did_you_mean(k, valid, what="settings"))
    kwargs = {}
    for k, v in node.items():
        default = getattr(cls(), k)
        if isinstance(default, (int, float)) and not isinstance(default, bool):
            v = _number(v, default, f"{path}.{k}", where)
        elif isinstance(default, str) and not isinstance(v, str):
            raise ConfigError(where, f"[{path}] {k} = {v!r} is not a string")
        kwargs[k] = v
    return cls(**kwargs)


def _number(v: Any, default: int | float, key: str, where: str) -> int | float:
    """A numeric setting: a finite number of the default's kind, inside limits.SETTINGS."""
    section_name, name = key.rsplit(".", 1)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ConfigError(where, f"[{section_name}] {name} = {v!r} is not a finite number")
    if isinstance(default, int):
        if not float(v).is_integer():
            raise ConfigError(where, f"[{section_name}] {name} = {v!r} is not a whole number")
        v = int(v)
    else:
        v = float(v)
    lo, hi = limits.SETTINGS.get(key, (-math.inf, math.inf))
    if not lo <= v <= hi:
        raise ConfigError(where, f"[{section_name}] {name} = {v!r} is outside {lo:g} … {hi:g}")
    return v


def known_sections(doc: dict[str, Any], sections: tuple[str, ...], where: str) -> None:
    """Refuse a recipe section nobody reads (a misspelt [detect.pach])."""
    def walk(node, prefix):
        for k, v in node.items():
            name = f"{prefix}{k}"
            if isinstance(v, dict):
                if name not in sections and not any(s.startswith(name + ".") for s in sections):
                    raise ConfigError(where, f"[{name}] is not a recipe section",
                                      did_you_mean(name, sections, what="sections", form="[{}]"))
                if name not in sections:
                    walk(v, name + ".")
    walk(doc, "")
