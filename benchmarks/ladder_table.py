"""One Markdown table of every task's ladder, from the JSON files ``benchmarks/ladder.py``
wrote (the README's summary):

    python benchmarks/ladder_table.py docs/data/ladder_*.json

A row per task: each policy's mean return with its 95% bootstrap interval, whether the ladder
is ordered and every step separated by its paired interval, and the oracle's wall time per
episode.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

ORDER = ["random", "best constant"]


def _cell(p: dict) -> str:
    m = p["mean"]
    return f"{m['value']:.3f} [{m['low']:.3f}, {m['high']:.3f}]"


def row(d: dict) -> str:
    pol = d["policies"]
    names = list(pol)
    hand = next(k for k in names if k not in ORDER and not k.startswith("oracle"))
    name = d.get("controller", {}).get("name", hand)
    oracle = next(k for k in names if k.startswith("oracle"))
    sep = all(s["separated"] for s in d["ladder"])
    ok = "yes" if d["ordered"] and sep else ("ordered" if d["ordered"] else "**no**")
    secs = d["oracle_budget"]["seconds_per_episode"]
    return (f"| `{d['env_id']}` | {_cell(pol['random'])} | {_cell(pol['best constant'])} | "
            f"{_cell(pol[hand])} ({name}) | **{_cell(pol[oracle])}** | {ok} | {secs:.1f} s |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("files", nargs="+", type=Path)
    args = ap.parse_args(argv)
    print("| task | random | best constant | hand-written | oracle | ordered, separated | "
          "oracle per episode |")
    print("|---|---|---|---|---|---|---|")
    for f in args.files:
        print(row(json.loads(f.read_text())))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
