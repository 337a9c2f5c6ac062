"""numba kernels, one module per physical effect.

- :mod:`.structs`: the dtypes and the named structs every kernel takes (``Discs``, ``Bounds``,
  ``Tables``, ``Counters``, ``Scratch``, ``Reactors``, ``Episodes``, ``ReactorConsts``).
- :mod:`.walls`: disc-wall contact times and specular reflection (box and circle).
- :mod:`.collisions`: disc-disc contact times and the impulse exchange with restitution.
- :mod:`.reactions`: reactive collisions, first-order reactions and the state writes of
  every reaction, shared by both integrators.
- :mod:`.celllist`: the O(N) neighbour grid.
- :mod:`.heap`: the event queues (a binary heap within a step; an indexed heap for the
  event-driven integrator).
- :mod:`.resolve`: the fallback that separates pairs left overlapping.
- :mod:`.placement`: placing and relocating discs without overlap.
- :mod:`.controls`: energy sums and the in-place pieces of the controls.
- :mod:`.step`: the time-stepped integrator, composing the effects a scene calls for.
- :mod:`.event_driven`: the exact event-driven integrator (its grid and predictions in
  :mod:`.event_predict`, its event handlers in :mod:`.event_handlers`, its structs in
  :mod:`.event_structs`).
- :mod:`.batch`: many reactors of an environment in one compiled call.

Kernels never touch global random state: a ``numpy.random.Generator`` is passed in.
See docs/architecture.md for how the layers fit together.
"""

from . import notice  # noqa: E402,F401  (logs once when a process compiles the kernels)
