#!/usr/bin/env python
"""discgym's own speed: disc-steps per second from N = 10^2 to 10^6 on one and on all
threads, and the cost of each effect (absent effects cost nothing).

    python benchmarks/bench_core.py           # the full run quoted in docs/performance.md
    python benchmarks/bench_core.py --quick   # a smoke run (no figures written)

Prints plain-text tables and writes docs/img/perf_scaling.png and docs/img/perf_effects.png
(unless ``--quick``). Any other option of ``discgym.bench`` may follow (``--help``), e.g.
``--markdown FILE`` or ``--sizes 1e3,1e4``.
"""

import sys
from pathlib import Path

from discgym.bench import main

IMG = Path(__file__).resolve().parents[1] / "docs" / "img"

if __name__ == "__main__":
    args = sys.argv[1:]
    plot = [] if "--quick" in args or "--plot" in args else ["--plot", str(IMG)]
    sys.exit(main(["--sections", "scaling,effects", *plot, *args]))
