"""Type aliases of granflow's annotations (only for type checkers: modules import this
under ``typing.TYPE_CHECKING``, so it costs nothing at run time)."""

import os
from typing import TypeAlias

import numpy as np
import numpy.typing as npt

__all__ = ["ArrayLike", "FloatArray", "FloatOrArray", "PathLike"]

#: Anything :func:`numpy.asarray` turns into numbers: a float, a list, an array.
ArrayLike: TypeAlias = npt.ArrayLike
#: A NumPy array of float64 [SI units].
FloatArray: TypeAlias = npt.NDArray[np.float64]
#: A file or folder: a string or a :class:`pathlib.Path`.
PathLike: TypeAlias = str | os.PathLike[str]
#: A float or a float array (what NumPy's broadcasting takes and gives).
FloatOrArray: TypeAlias = float | npt.NDArray[np.float64]
