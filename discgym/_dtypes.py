"""The array dtypes (defined with the kernels' structs in :mod:`discgym.kernels.structs`)."""

from .kernels.structs import COUNT, FLOAT, INDEX

__all__ = ["COUNT", "FLOAT", "INDEX"]
