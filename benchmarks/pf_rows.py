"""The particle filters' section of docs/benchmarks.md alone (`make bench` writes it with the
rest): the compiled kernels against their numpy reference at 500, 5,000 and 50,000 particles
and where a pf-constraint frame goes (pf_profile.py), measured now and put in place of the
file's "## Particle filters" section; the other sections are left as they are.

    nice .venv/bin/python benchmarks/pf_rows.py
"""

from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"  # the filters on one core, as in run.py

import tempfile  # noqa: E402

from filters import pf_vs_reference  # noqa: E402  (benchmarks/ is on sys.path)
from pf_profile import passes  # noqa: E402
from report import pf_section  # noqa: E402
from run import PAPER_S_PER_FRAME, REPO, prepared  # noqa: E402


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        _, _, s, inp, proj, arm, x0, P0 = prepared(tmp)
        res = {"paper": PAPER_S_PER_FRAME, "pf_load": os.getloadavg()[0]}
        res["pf"] = pf_vs_reference(inp, proj, arm, x0, P0, s)
        res["pf_passes"] = passes()
    path = REPO / "docs" / "benchmarks.md"
    text = path.read_text()
    start = text.index("\n## Particle filters")
    end = text.index("\n## ", start + 1)
    section = "\n".join(pf_section(res) + [""])
    path.write_text(text[:start] + section + text[end:])
    print(section)


if __name__ == "__main__":
    main()
