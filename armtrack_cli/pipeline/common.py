"""What every stage's orchestration shares: where outputs go, the resolved recipe (and fuse's
settings from it), and the memory a finished phase freed handed back (or never kept:
``large_arrays_mapped``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from armtrack_cli.core.methods import DEFAULT_FOR_KIND
from armtrack_cli.fuse.settings import FuseSettings, checked, with_flags
from armtrack_cli.session.config import Session
from armtrack_cli.session.recipe import apply_overrides, known_sections, load_recipe, section

M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3  # glibc's malloc.h
MAPPED_FROM_MB = 2  # large_arrays_mapped's threshold: above a smoother block's F or Q at d = 15
#                     (1.8 MB, allocated and freed hundreds of times a pass: from the heap)
TRIM_FROM_MB = 32  # the heap's free top kept up to this (glibc's default once its thresholds
#                    are fixed, 128 kB, gave back and faulted in again ~350 MB of pages a
#                    long-10 run: 100,000 page faults against 11,000, +0.2-0.4 s)
_mapped = {"set": False}

RECIPE_SECTIONS = ("calibrate", "detect.patch", "detect.palm", "fuse", "fuse.pf", "fuse.models",
                   "ukf_palm")


def out_dir(session: Session, override: str | Path | None) -> Path:
    return Path(override) if override is not None else session.out_dir


def resolve_recipe(recipe: str | None, sets: tuple[str, ...]) -> tuple[dict[str, Any], str]:
    doc, where = load_recipe(recipe)
    doc = apply_overrides(doc, sets)
    if sets:  # a value that is wrong came from the recipe or --set: name both
        where = "--set" if where == "defaults" else f"{where} with --set"
    known_sections(doc, RECIPE_SECTIONS, where)
    return doc, where


def settings_for(recipe: str | None, sets: tuple[str, ...], *, method: str | None = None,
                 particles: int | None = None, seed: int | None = None,
                 kind: str | None = None) -> tuple[FuseSettings, str]:
    """[fuse] from defaults < recipe < --set < explicit flags, checked; and where it came from.
    With ``kind`` (a session's), the method that neither a flag nor the recipe names is that
    kind's default (core.methods.DEFAULT_FOR_KIND). Here, not in
    pipeline/fuse.py: `armtrack run` checks it before it loads fuse's libraries."""
    doc, where = resolve_recipe(recipe, sets)
    if method is None and kind is not None and "method" not in doc.get("fuse", {}):
        method = DEFAULT_FOR_KIND[kind]
    s = with_flags(section(doc, "fuse", FuseSettings, where), method=method,
                   particles=particles, seed=seed)
    return checked(s, where), where


def release_memory() -> None:
    """What a finished stage (or a phase of one: fuse's reading, its method) freed, handed
    back to the system before the next starts, so that in one process their peaks do not add
    up (issue 15): the reference cycles Python has not collected yet, and glibc's free pages
    (malloc_trim, every arena's: the decoding thread's arena otherwise keeps the pages its
    frames had; freed arrays inside the heap stay resident until trimmed). A no-op without
    glibc."""
    import ctypes
    import gc

    gc.collect()
    try:
        ctypes.CDLL(None).malloc_trim(0)
    except (OSError, AttributeError):  # not glibc
        pass


def large_arrays_mapped() -> None:
    """Every allocation of MAPPED_FROM_MB or more in a mapping of its own, whose pages go back
    to the system the moment it is freed (glibc's mallopt M_MMAP_THRESHOLD; once a process, a
    no-op without glibc). glibc's own threshold moves: it rises to the largest mapped block
    freed so far (up to 32 MB), so once fuse has freed one session-long array (a 60-minute
    session's IMU, the first pass's covariances) the next ones of that size come from its
    heap, where what is freed stays resident until trimmed and a block still in use above it
    keeps it all: fuse@60's RssAnon rose to 207-213 MB with the moving threshold, 190-191
    with this fixed one (issue 15)."""
    if _mapped["set"]:
        return
    _mapped["set"] = True
    import ctypes

    try:
        libc = ctypes.CDLL(None)
        libc.mallopt(M_MMAP_THRESHOLD, int(MAPPED_FROM_MB * 2**20))
        libc.mallopt(M_TRIM_THRESHOLD, int(TRIM_FROM_MB * 2**20))
    except (OSError, AttributeError):  # not glibc
        pass
