"""numba kernels, one module per physical effect.

- :mod:`.walls`: disc-wall contact times and specular reflection (box and circle).
- :mod:`.collisions`: disc-disc contact times and the impulse exchange with restitution.
- :mod:`.reactions`: reactive collisions and first-order (unimolecular) reactions.
- :mod:`.celllist`: the O(N) neighbour grid.
- :mod:`.heap`: the event queue that orders contacts within a step.
- :mod:`.step`: the driver that composes the effects a scene calls for.

Kernels take plain struct-of-arrays state (``pos`` (N, 2), ``vel`` (N, 2), ``spc`` (N,),
``uint`` (N,)) and never touch global random state: a ``numpy.random.Generator`` is passed in.
"""
