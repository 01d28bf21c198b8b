"""What every stage's orchestration shares: where outputs go, and the resolved recipe."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from armtrack_cli.session.config import Session
from armtrack_cli.session.recipe import apply_overrides, known_sections, load_recipe

RECIPE_SECTIONS = ("calibrate", "detect.patch", "detect.palm", "fuse", "fuse.pf", "fuse.models")


def out_dir(session: Session, override: str | Path | None) -> Path:
    return Path(override) if override is not None else session.out_dir


def resolve_recipe(recipe: str | None, sets: tuple[str, ...]) -> tuple[dict[str, Any], str]:
    doc, where = load_recipe(recipe)
    doc = apply_overrides(doc, sets)
    if sets:  # a value that is wrong came from the recipe or --set: name both
        where = "--set" if where == "defaults" else f"{where} with --set"
    known_sections(doc, RECIPE_SECTIONS, where)
    return doc, where
