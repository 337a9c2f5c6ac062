"""What the command lines of agents/ share: the arguments' ranges declared on their dataclass
fields, one validation pass that runs before anything is written, one top-level handler that
prints an expected error (a bad argument, a missing or incomplete run, a corrupted file) as one
line with exit status 2, and run folders that are complete or absent.

- :class:`Range` in a field's ``Annotated`` metadata gives its allowed interval;
  :func:`check_fields` checks every field of an arguments dataclass against its type
  (``int`` is not a bool, a ``Literal``'s choices, ``| None``) and its range.
- :func:`usage` builds a :class:`UsageError` naming the flag; :func:`run` prints it as
  ``<script>: error: --flag: ...`` and exits 2. Any other exception keeps its traceback: it is
  a bug, not the user's input.
- :func:`parse` is ``tyro.cli`` with its parse errors (a non-integer, an unknown choice) cut
  to the same one line.
- :func:`staged_folder`: a trainer writes into a hidden sibling of its output folder and
  renames it into place once every file is written, so that an interrupted or crashed run
  leaves no run folder behind.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import os
import re
import shutil
import sys
import tempfile
import typing
from pathlib import Path

#: Largest seed: SB3 and RLlib seed numpy's global generator, which takes [0, 2**32 - 1].
MAX_SEED = 2**32 - 1
#: The file that marks a train_ppo.py folder as finished (written last, then the rename).
SUMMARY = "train_summary.json"
#: What a hidden staging folder's name contains; evaluate.py refuses such folders.
PARTIAL = ".partial-"


class UsageError(ValueError):
    """An error in what the user gave (an argument, a run folder, a file): :func:`run`
    prints its one line and exits 2, no traceback."""


def flag(name: str) -> str:
    """The command-line flag of a dataclass field: ``n_envs`` -> ``--n-envs``."""
    return name if name.startswith("--") else "--" + name.replace("_", "-")


def usage(name: str, message: str) -> UsageError:
    """A :class:`UsageError` naming the flag of field ``name``, on one line."""
    return UsageError(f"{flag(name)}: {one_line(message)}")


def one_line(text) -> str:
    return " ".join(str(text).split())


@dataclasses.dataclass(frozen=True)
class Range:
    """A numeric field's allowed interval, both ends included (None: unbounded)."""

    lo: float | None = None
    hi: float | None = None

    def __str__(self) -> str:
        if self.hi is None:
            return f">= {self.lo}"
        return f"in [{self.lo}, {self.hi}]" if self.lo is not None else f"<= {self.hi}"

    def contains(self, v) -> bool:
        return (self.lo is None or v >= self.lo) and (self.hi is None or v <= self.hi)


def _matches(value, tp) -> bool:
    """Whether ``value`` is of the annotation ``tp`` (the forms the agents' dataclasses use:
    int, float, str, bool, Path, Literal, X | None, list[X])."""
    origin, targs = typing.get_origin(tp), typing.get_args(tp)
    if tp is type(None):
        return value is None
    if origin is typing.Literal:
        return any(value == a and type(value) is type(a) for a in targs)
    if origin is typing.Union or type(tp).__name__ == "UnionType":
        return any(_matches(value, a) for a in targs)
    if origin is list:
        return isinstance(value, (list, tuple)) and all(_matches(v, targs[0]) for v in value)
    if tp is bool:
        return isinstance(value, bool)
    if tp is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if tp is float:
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if tp is Path:
        return isinstance(value, (str, os.PathLike))
    return isinstance(value, tp)


def _describe(tp) -> str:
    origin, targs = typing.get_origin(tp), typing.get_args(tp)
    if origin is typing.Literal:
        return "one of " + ", ".join(repr(a) for a in targs)
    if origin is typing.Union or type(tp).__name__ == "UnionType":
        return " or ".join(_describe(a) for a in targs)
    if origin is list:
        return f"a list of {_describe(targs[0])}"
    return "None" if tp is type(None) else f"{'an' if tp is int else 'a'} {tp.__name__}"


def check_fields(args) -> None:
    """Every field of the dataclass ``args`` against its type and :class:`Range`: the
    refusal names the flag."""
    hints = typing.get_type_hints(type(args), include_extras=True)
    for f in dataclasses.fields(args):
        tp, meta = hints[f.name], ()
        if typing.get_origin(tp) is typing.Annotated:
            tp, *meta = typing.get_args(tp)
        value = getattr(args, f.name)
        ranges = [m for m in meta if isinstance(m, Range)]
        if not _matches(value, tp):
            want = _describe(tp) + "".join(f" {r}" for r in ranges)
            raise usage(f.name, f"expected {want}, got {value!r}")
        for r in ranges:
            if value is not None and not r.contains(value):
                kind = _describe(int if isinstance(value, int) else float)
                raise usage(f.name, f"expected {kind} {r}, got {value!r}")


def check_out_folder(path, name: str = "out", marker: str = "args.json") -> Path:
    """An output folder a trainer may (re)place: absent, empty, or a previous run folder of
    the agents' scripts (it holds ``marker``); under a parent that is a folder, or can be
    made one, and writable."""
    path = Path(path)
    if path.name in ("", ".", ".."):
        raise usage(name, f"{str(path)!r} names no folder of its own")
    if path.exists() or path.is_symlink():
        if not path.is_dir() or path.is_symlink():
            raise usage(name, f"{path} exists and is not a folder")
        if any(path.iterdir()) and not (path / marker).exists():
            raise usage(name, f"{path} exists and is not a run folder (no {marker}); the "
                              f"run would replace it: name another folder")
    parent = path.absolute().parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise usage(name, f"{parent} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise usage(name, f"{parent} is not writable")
    return path


def check_json_object(text: str, name: str) -> dict:
    import json

    try:
        value = json.loads(text)
    except json.JSONDecodeError as e:
        raise usage(name, f"not JSON ({e}): {text!r}") from None
    if not isinstance(value, dict):
        raise usage(name, f"expected a JSON object ({{...}}), got {text!r}")
    return value


def check_task(env_id, name: str = "env_id") -> type:
    """The env class of a discgym task, found through Gymnasium's registry (``gym.spec``, whose
    message suggests near names), else a refusal naming ``name``."""
    import gymnasium as gym

    import discgym  # noqa: F401  (registers the tasks)
    from discgym.tasks import TASKS

    try:
        gym.spec(env_id)
    except gym.error.Error as e:
        raise usage(name, f"{env_id!r}: {e} (discgym's tasks: {', '.join(TASKS)})") from None
    if env_id not in TASKS:
        raise usage(name, f"{env_id!r} is a Gymnasium env but not a discgym task "
                          f"({', '.join(TASKS)})")
    return TASKS[env_id][0]


def check_env_kwargs(env_cls: type, kwargs: dict, name: str) -> None:
    """Keyword arguments of a task's reactor, validated as the env will (discgym's
    ``ReactorConfig.from_kwargs``: type, range, a scene that loads, discs that fit), without
    building the env."""
    from discgym.env import ReactorConfig

    try:
        ReactorConfig.from_kwargs(env_cls.defaults, **kwargs)
    except (TypeError, ValueError, OSError) as e:
        msg = str(e).replace("ReactorConfig.from_kwargs()", "the env")
        for key in kwargs:  # ("scene: cannot read ..." after --scene: said once)
            if flag(key) == flag(name):
                msg = msg.removeprefix(f"{key}: ")
        raise usage(name, msg) from None


# ----------------------------------------------------------------------- the command line


_BOX = re.compile(r"[\u2500-\u257f]+")  # (the box drawing of tyro's error panels)
_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")


def parse(cls, argv=None, description: str | None = None):
    """``tyro.cli(cls)``; a parse error (a value of the wrong type, an unknown choice or
    flag) is printed as the first paragraph of tyro's message, on one line, then exit 2 as
    tyro does. ``--help`` is tyro's own."""
    import tyro

    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err):
            return tyro.cli(cls, args=argv, description=description)
    except SystemExit as e:
        text = _ANSI.sub("", err.getvalue())
        if e.code in (0, None) or not text.strip():
            sys.stderr.write(text)
            raise
        print(f"{_prog()}: error: {_first_paragraph(text)}", file=sys.stderr, flush=True)
        raise SystemExit(2) from None


def _first_paragraph(text: str) -> str:
    words = []
    for line in text.splitlines():
        if line.lstrip().startswith("\u256d"):  # (╭─ Title ─╮: the panel's title, skipped)
            continue
        inner = _BOX.sub("", line).strip(" \u2502")  # (│: the panel's sides)
        if not inner:
            if words:
                break  # (a blank row or a rule: the end of the first paragraph)
            continue
        if inner.startswith(("usage:", "For full helptext")):
            continue
        words.append(inner)
    return one_line(" ".join(words)) or one_line(text)


def _prog() -> str:
    return Path(sys.argv[0]).name if sys.argv and sys.argv[0] else "agents"


def run(main) -> typing.NoReturn:
    """Run ``main()`` as a script's top level: exit with its return value if that is an int
    (0 otherwise); a :class:`UsageError` (anything the user gave that cannot be used) is
    printed as one line and exits 2; Ctrl-C (or SIGTERM, turned into the same
    ``KeyboardInterrupt`` so that :func:`staged_folder` cleans up) exits 130 with one line.
    Every other exception is a bug and keeps its traceback."""
    import signal

    def terminate(signum, frame):  # (kill, a job scheduler: clean up as for Ctrl-C)
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, terminate)
    try:
        code = main()
    except UsageError as e:
        print(f"{_prog()}: error: {one_line(e)}", file=sys.stderr, flush=True)
        raise SystemExit(2) from None
    except KeyboardInterrupt:
        print(f"{_prog()}: interrupted", file=sys.stderr, flush=True)
        raise SystemExit(130) from None
    finally:
        signal.signal(signal.SIGTERM, previous)
    raise SystemExit(code if isinstance(code, int) and not isinstance(code, bool) else 0)


# ------------------------------------------------------------------ complete or absent


@contextlib.contextmanager
def staged_folder(final, name: str = "out"):
    """Yield a fresh hidden sibling of ``final`` to write a run into; when the block ends
    without an exception, rename it to ``final`` (a previous folder there, checked by
    :func:`check_out_folder`, is replaced; the two renames are the only moment neither
    exists). On any exception (Ctrl-C included) the sibling is removed, with the parent
    folders this made, so ``final`` is complete or absent. (A process killed outright leaves
    its ``.<name>.partial-*`` sibling, which evaluate.py refuses.)"""
    final = Path(final)
    parent = final.absolute().parent
    made = []
    p = parent
    while not p.exists():
        made.append(p)
        p = p.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}{PARTIAL}", dir=parent))
    except OSError as e:  # (a parent that cannot hold folders: /proc, a read-only disk)
        _remove_empty(made)
        raise usage(name, f"cannot make a folder in {parent}: {e.strerror or e}") from None
    os.chmod(tmp, 0o777 & ~_umask())  # (mkdtemp makes it private; a run folder is not)
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        _remove_empty(made)
        raise
    if final.exists():
        old = Path(tempfile.mkdtemp(prefix=f".{final.name}.old-", dir=parent))
        os.replace(final, old / final.name)
        os.replace(tmp, final)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(tmp, final)


def _remove_empty(folders) -> None:
    for p in folders:  # (innermost first; only if still empty)
        with contextlib.suppress(OSError):
            p.rmdir()


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and a rename: the file is whole
    or as it was."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
