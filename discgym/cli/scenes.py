"""``discgym scenes`` and ``discgym show``: the built-in scenes, and one scene in detail or as
TOML."""

from __future__ import annotations

import math
import sys

from .common import (
    EXIT_OK,
    CLIError,
    fmt,
    load_scene,
    table,
    writable,
)

# --------------------------------------------------------------------------------------------
# discgym scenes / show


def cmd_scenes(args) -> int:
    import discgym as dg

    desc = dg.scenes.describe()
    print(table([(n, d) for n, d in desc.items()]))
    print("\nInspect one with `discgym show NAME`; run one with "
          "`discgym run NAME --time 20 --plot out.png`.")
    return EXIT_OK


def _describe_bounds(b) -> str:
    if b.kind == "box":
        return (f"box {fmt(b.width)} x {fmt(b.height)} from ({fmt(b.origin[0])}, "
                f"{fmt(b.origin[1])}), area {fmt(b.area)}")
    return (f"circle of radius {fmt(b.radius)} around ({fmt(b.center[0])}, "
            f"{fmt(b.center[1])}), area {fmt(b.area)}")


def _reaction_params(r) -> str:
    if r.kind in ("transformation", "decomposition"):
        return f"probability {fmt(r.probability)} per unit time"
    s = f"activation energy {fmt(r.activation_energy)}"
    if r.kind == "combination":
        s += f", reverse probability {fmt(r.reverse_probability)} per unit time"
    return s


def scene_summary(scene) -> str:
    """A human-readable description of a scene (what ``discgym show`` prints)."""
    lines = []
    title = scene.name or "(unnamed scene)"
    lines.append(f"{title}: {scene.description}" if scene.description else title)
    lines.append("")
    lines.append(f"bounds       {_describe_bounds(scene.bounds)}")
    lines.append(f"dt {fmt(scene.dt)}, temperature {fmt(scene.temperature)}, restitution "
                 f"{fmt(scene.restitution)}, internal relaxation "
                 f"{fmt(scene.internal_relaxation)}, max displacement "
                 f"{fmt(scene.max_displacement)}, collisions "
                 f"{'on' if scene.collisions else 'off'}")
    lines.append("")
    rows = [(s.name, fmt(s.radius), fmt(s.mass), fmt(s.formation_energy),
             scene.counts.get(s.name, 0)) for s in scene.species]
    lines.append(table(rows, header=("species", "radius", "mass", "formation energy",
                                      "default count")))
    area = sum(math.pi * s.radius ** 2 * scene.counts.get(s.name, 0) for s in scene.species)
    lines.append(f"packing fraction of the default counts: {area / scene.bounds.area:.3f}")
    lines.append("")
    if scene.reactions:
        lines.append("reactions")
        lines.append(table([("  " + r.kind, r.label(), _reaction_params(r))
                             for r in scene.reactions]))
    else:
        lines.append("reactions    none")
    return "\n".join(lines)


def cmd_show(args) -> int:
    scene = load_scene(args.scene)
    if args.toml == "-":
        sys.stdout.write(scene.to_toml())
        return EXIT_OK
    print(scene_summary(scene))
    if args.toml:
        p = writable(args.toml, "--toml")
        if p.exists() and not args.force:
            raise CLIError(f"--toml {args.toml}: the file exists (it may hold your edits); "
                           "add --force to overwrite it")
        p.write_text(scene.to_toml())
        print(f"\nwrote {p}: edit it, then `discgym run {p} --time 20`")
    return EXIT_OK
