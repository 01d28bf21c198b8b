"""This process's memory as Linux reports it (/proc/self/status), for the figures issue 15
asks for: a stage moved into a process of its own (pipeline/apart.py) says how much it and
its caller held at once."""

from __future__ import annotations


def status_mb(key: str) -> float:
    """/proc/self/status's ``key`` (VmHWM: the peak resident memory; RssAnon: the anonymous
    part now), MB; 0 where there is none (not Linux)."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(key + ":"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return 0.0
