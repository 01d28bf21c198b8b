"""This process's memory as Linux reports it (/proc/self/status), for the figures issue 15
asks for: a stage moved into a process of its own (pipeline/apart.py) says how much it and
its caller held at once; benchmarks/fuse_memory.py samples a stage's phases with it."""

from __future__ import annotations


def status(*keys: str) -> dict[str, float]:
    """/proc/self/status's ``keys`` (VmHWM: the peak resident memory; RssAnon: the anonymous
    part now; RssFile: the files' pages mapped now), MB, from one read; 0 for a key it does
    not hold (not Linux)."""
    out = dict.fromkeys(keys, 0.0)
    try:
        with open("/proc/self/status") as f:
            for line in f:
                key = line.split(":", 1)[0]
                if key in out:
                    out[key] = int(line.split()[1]) / 1024
    except OSError:
        pass
    return out


def status_mb(key: str) -> float:
    """/proc/self/status's ``key``, MB (status)."""
    return status(key)[key]
