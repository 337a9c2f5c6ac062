"""Render one episode of every task under its hand-written controller into
``docs/img/tasks/<id>.gif`` (the GIF on each task page).

The frames are those of the evaluation GIFs (``agents/evaluate.py``'s ``animate``, which made
``docs/img/flagship_episode.gif``): the reactor (``render_mode="rgb_array"``, discgym's
numpy renderer) beside its species counts step by step. Run once after a change that alters
what an episode looks like; the docs build only references the files::

    python docs/_scripts/make_gifs.py            # every task, seed 0
    python docs/_scripts/make_gifs.py --env-id DiscFlow-v0

Needs the ``agents`` extra (matplotlib, Pillow; ``agents/evaluate.py`` imports its training
helpers).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "docs" / "img" / "tasks"
#: Keep each GIF small: the pages load all of it.
MAX_BYTES = 1_500_000


def main(argv=None) -> int:
    sys.path.insert(0, str(ROOT / "agents"))
    from evaluate import animate

    import discgym
    from discgym.controllers import controller_for

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--env-id", action="append", choices=sorted(discgym.tasks.TASKS),
                   help="a task (repeatable; default: every task)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--every", type=int, default=3, help="a frame every N env steps")
    p.add_argument("--size", type=int, default=240, help="the reactor's side in pixels")
    a = p.parse_args(argv)
    OUT.mkdir(parents=True, exist_ok=True)
    for env_id in a.env_id or list(discgym.tasks.TASKS):
        path = animate(env_id, controller_for, OUT / f"{env_id}.gif", a.seed, every=a.every,
                       size=a.size)
        size = path.stat().st_size
        print(f"wrote {path.relative_to(ROOT)} ({size / 1e6:.2f} MB)")
        if size > MAX_BYTES:
            print(f"{path.name}: {size} bytes, more than {MAX_BYTES}: use a larger --every "
                  "or a smaller --size", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
