"""The work folder (SESSION/armtrack/ or --out): where each stage reads its predecessors'
outputs and writes its own. The pipeline asks it what is there and how old it is; it never
probes the file system itself."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


def _mtime(path: Path) -> float | None:
    """Modification time of a file, or the newest file inside a folder; None if absent."""
    try:
        if path.is_dir():
            times = [p.stat().st_mtime for p in path.rglob("*") if p.is_file()]
            return max(times, default=path.stat().st_mtime)
        return path.stat().st_mtime
    except OSError:
        return None


def newest(paths) -> float | None:
    """The newest modification time of ``paths`` (files or folders); None when any is
    missing (then whatever depends on them cannot be up to date)."""
    times = [_mtime(Path(p)) for p in paths]
    return None if any(t is None for t in times) else max(times, default=0.0)


@dataclass(frozen=True)
class WorkFolder:
    path: Path

    def __truediv__(self, name: str) -> Path:
        return self.path / name

    def has(self, name: str) -> bool:
        return (self.path / name).is_file()

    def oldest(self, names) -> float | None:
        """The oldest of these outputs; None when one is missing (the stage must run)."""
        times = [_mtime(self.path / n) for n in names]
        return None if any(t is None for t in times) else min(times, default=0.0)

    def trajectories(self, methods) -> tuple[str, ...]:
        """The methods, of ``methods``, whose trajectory-METHOD.csv is here."""
        return tuple(m for m in methods if self.has(f"trajectory-{m}.csv"))
