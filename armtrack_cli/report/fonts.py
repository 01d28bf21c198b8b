"""Fonts for text the report did not write itself (a subject's name in Chinese, Japanese,
Korean, Greek, Arabic, …): DejaVu Sans first, then installed fonts that have the characters
it lacks, through matplotlib's font fallback (a list of families). A character no installed
font has prints as a box: one warning line says which and what to install, instead of
matplotlib's warning for every glyph on every page."""

from __future__ import annotations

import logging
import re
import warnings
from contextlib import contextmanager

BASE = "DejaVu Sans"
# tried first, in this order (well-made, wide coverage); then any other installed font
PREFERRED = ("Noto Sans CJK JP", "Noto Sans CJK SC", "Noto Sans CJK TC", "Noto Sans CJK KR",
             "Source Han Sans", "WenQuanYi Zen Hei", "WenQuanYi Micro Hei", "Droid Sans Fallback",
             "Noto Sans", "Noto Sans Arabic", "Noto Sans Hebrew", "Noto Sans Devanagari",
             "Noto Sans Thai", "FreeSans", "Unifont")
LAST_RESORT = "Last Resort"  # matplotlib's own: a box naming the code point, for any character
GLYPH = re.compile(r"Glyph (\d+) \(.*\) missing from font")


def _charmap(path: str) -> set[int]:
    from matplotlib import ft2font

    try:
        return set(ft2font.FT2Font(path).get_charmap())
    except (OSError, RuntimeError, ValueError):  # unreadable font file: it offers nothing
        return set()


def _candidates() -> list[tuple[str, str]]:
    """(family, file) of every installed font, preferred ones first: matplotlib's list and
    the system's font folders (a font installed after matplotlib built its cache is only in
    the latter)."""
    from matplotlib import font_manager as fm

    known = {e.fname: e.name for e in fm.fontManager.ttflist}
    for path in fm.findSystemFonts():
        if path not in known:
            try:
                known[path] = fm.ttfFontProperty(fm.ft2font.FT2Font(path)).name
            except (OSError, RuntimeError, ValueError, KeyError):
                continue
    rank = {n: i for i, n in enumerate(PREFERRED)}
    return sorted(((n, p) for p, n in known.items()
                   if n != BASE and not n.startswith(LAST_RESORT)),
                  key=lambda x: (rank.get(x[0], len(rank)), x[0], x[1]))


def families(texts) -> tuple[list[str], str]:
    """([BASE, fallback families…], the characters no installed font has). Only BASE when it
    has every character (the PDF then has the same bytes as before fallbacks existed)."""
    from matplotlib import font_manager as fm

    chars = {ord(c) for t in texts for c in str(t) if not c.isspace() and c.isprintable()}
    need = chars - _charmap(fm.findfont(BASE, fallback_to_default=False))
    if not need:
        return [BASE], ""
    out = [BASE]
    for name, path in _candidates():
        have = need & _charmap(path)
        if have and name not in out:
            fm.fontManager.addfont(path)  # harmless when known; needed when the cache is older
            out.append(name)
            need -= have
        if not need:
            break
    return out, "".join(chr(c) for c in sorted(need))


def missing_warning(chars: str) -> str:
    return (f"no installed font has the characters {' '.join(chars)} (of the subject's name "
            "or other session text): they print as boxes in the report; install a font that "
            "has them (e.g. Debian's fonts-noto-cjk for Chinese, Japanese and Korean)")


@contextmanager
def one_glyph_warning(expected: str = ""):
    """matplotlib's "Glyph … missing" warnings, one for each glyph on each page, held back
    and said once (as ``missing_warning``) at the end; other warnings pass through. The font
    manager's log line for each bold text set in a fallback font without a bold face (it
    uses the regular one) is silenced meanwhile."""
    log = logging.getLogger("matplotlib.font_manager")
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            yield
    finally:
        log.setLevel(level)
    chars = set(expected)
    for w in caught:
        m = GLYPH.search(str(w.message))
        if m:
            chars.add(chr(int(m.group(1))))
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if chars:
        warnings.warn(missing_warning("".join(sorted(chars))), stacklevel=3)
