"""CI's low-end venv: the installed numba, numpy and gymnasium are the pins of .ci/lowest.txt
(pip may not have upgraded one for another package), and the kernel layer is the one that
numba gets (plain njit where the linked-only layer was not tested)."""

import sys
from importlib.metadata import version
from pathlib import Path

from packaging.version import Version

pins = {}
for line in (Path(__file__).parent / "lowest.txt").read_text().splitlines():
    line = line.split("#", 1)[0].strip()
    if line:
        name, _, v = line.partition("==")
        pins[name] = v
wrong = {n: version(n) for n, v in pins.items() if Version(version(n)) != Version(v)}
if wrong:
    sys.exit(f".ci/lowest_check.py: installed {wrong}, pinned {pins}")

from discgym.kernels import jit  # noqa: E402

print(f"low end: {', '.join(f'{n} {version(n)}' for n in pins)}; kernel layer {jit.LAYER}")
