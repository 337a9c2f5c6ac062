#!/usr/bin/env bash
# The wheel alone: build discgym's wheel, install it (not editable) in a fresh venv and, from
# outside the source tree (so the checkout cannot be imported instead), check that the package
# imported is the installed one, that every registered discgym task makes (single and native
# vector env), that every scene TOML of the tree is shipped and loads, that the compile
# helper's plans and the trained agents are shipped, and that the CLI runs.
# Cheap (about a minute, mostly pip): gymnasium.make compiles nothing and a native vector
# env's construction a few small functions (~2 s); the kernels compile at the first reset
# (~20 s), which this leaves to the test suite. Usage: bash .ci/wheel_check.sh (from anywhere)
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
PYTHON="${PYTHON:-python3}"
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT

# the wheel is built from the sdist (python -m build's default), so a file the sdist leaves
# out, or a stale build/ of a working tree, shows here too
"$PYTHON" -m venv "$TMP/build-venv"
"$TMP/build-venv/bin/python" -m pip install --quiet --upgrade pip build
"$TMP/build-venv/bin/python" -m build --outdir "$TMP/dist" "$ROOT" >"$TMP/build.log" 2>&1 \
    || { cat "$TMP/build.log"; exit 1; }
WHEEL="$(ls "$TMP"/dist/discgym-*.whl)"

"$PYTHON" -m venv "$TMP/venv"
"$TMP/venv/bin/python" -m pip install --quiet --upgrade pip
"$TMP/venv/bin/python" -m pip install --quiet "$WHEEL"
"$TMP/venv/bin/python" -m pip check

mkdir "$TMP/run"
cd "$TMP/run"
# (no PYTHONPATH: nothing but the venv's site-packages may provide discgym)
env -u PYTHONPATH "$TMP/venv/bin/python" - "$ROOT" <<'EOF'
import sys
import sysconfig
from pathlib import Path

import gymnasium as gym

import discgym

root = Path(sys.argv[1])
site = Path(sysconfig.get_paths()["purelib"]).resolve()
where = Path(discgym.__file__).resolve()
assert where.is_relative_to(site), f"discgym imported from {where}, not from {site}"

ids = sorted(k for k, spec in gym.registry.items() if str(spec.entry_point).startswith("discgym"))
assert ids == sorted(discgym.tasks.TASKS), (ids, sorted(discgym.tasks.TASKS))
for env_id in ids:
    gym.make(env_id).close()
    gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point").close()

shipped = discgym.scenes.names()
in_tree = sorted(p.stem for p in (root / "discgym" / "scenes").glob("*.toml"))
assert shipped == in_tree, f"scenes shipped {shipped}, in the tree {in_tree}"
for name in shipped:
    discgym.scenes.load(name)

# the compile helper's plans are shipped (for the numba they were recorded with)
from discgym.kernels import helper  # noqa: E402

assert helper.PLANS_FILE.is_file(), f"no {helper.PLANS_FILE}"
assert helper.load_plans() or __import__("numba").__version__ != \
    __import__("json").loads(helper.PLANS_FILE.read_text())["numba"], "plans unreadable"

# the trained agents are shipped and load (numpy only)
from discgym import pretrained  # noqa: E402

in_tree = {p.parent.name for p in (root / "discgym" / "agents").glob("*/agents.json")}
assert set(pretrained.available()) == in_tree, (pretrained.available(), in_tree)
for env_id, seeds in pretrained.available().items():
    for seed in seeds:
        pretrained.load(env_id, seed)

print(f"discgym {discgym.__version__} from {where.parent}: made {', '.join(ids)}; "
      f"{len(shipped)} scenes")
EOF
env -u PYTHONPATH "$TMP/venv/bin/discgym" --help >/dev/null
echo "wheel check passed: $(basename "$WHEEL")"
