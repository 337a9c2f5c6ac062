#!/usr/bin/env python
"""discgym against pymunk (Chipmunk2D) on the same scene and time step: particle-steps per
second and their ratio, each one's wall pressure against Henderson's equation of state, and
the overlaps each leaves. Needs pymunk (``pip install 'discgym[bench]'``); without it only
discgym's side is measured and a note says so.

    python benchmarks/bench_peers.py           # the full run quoted in docs/performance.md
    python benchmarks/bench_peers.py --quick   # N = 10^3 only (no figure written)

Prints plain-text tables and writes docs/img/perf_peers.png (unless ``--quick``). Any other
option of ``discgym.bench`` may follow (``--help``), e.g. ``--peers 1e3@0.05,1e4@0.02``.
"""

import sys
from pathlib import Path

from discgym.bench import main

IMG = Path(__file__).resolve().parents[1] / "docs" / "img"

if __name__ == "__main__":
    args = sys.argv[1:]
    plot = [] if "--quick" in args or "--plot" in args else ["--plot", str(IMG)]
    sys.exit(main(["--sections", "peers", *plot, *args]))
