"""The one place where array dtypes are chosen.

Every array handed to a compiled kernel is created with one of these, so a kernel is compiled
for exactly one signature and the on-disk numba cache is reused across runs.
"""

import numpy as np

FLOAT = np.float64  #: positions, velocities, energies, times
INDEX = np.int32  #: species indices, disc indices in cell lists and event queues
COUNT = np.int64  #: event counters and stamps (never overflow in practice)
