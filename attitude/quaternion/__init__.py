"""Quaternion algebra and conversions between attitude representations.

The algebra (product, rotation of vectors, distance, interpolation) is in ``_algebra``, the
conversions to every other attitude representation (matrices, axis and angle, rotation vectors,
Euler angles of all twelve sequences, MRPs, scipy rotations) in ``_conversions``; every name is
imported from here.

Conventions (see ``docs/conventions.md`` for the full page with the seed equations):

* A quaternion is a plain float array of shape ``(..., 4)``, **scalar first** ``(w, x, y, z)``;
  vectors are arrays of shape ``(..., 3)``. Every function broadcasts over leading dimensions.
* The product is Hamilton's, ``a∘b = (a0 b0 − a·b, a0 b + b0 a + a × b)`` (Schwab eq. 2;
  Arribas et al. Sect. 2), so ``i∘j = k``.
* An attitude ``q`` maps **body** components to **space** (inertial) components,
  ``x_S = q∘x_B∘q̃`` (Schwab eq. 5, Arribas et al. Theorem 1). :func:`to_matrix` is the active
  matrix ``R`` with ``x_S = R x_B`` (Schwab eq. 7); the direction-cosine matrix printed in Arribas
  et al. Sect. 2 is its transpose.
* Euler angles are intrinsic (body-axis) sequences named by digits: ``"313"`` is
  ``q = q_3(φ)∘q_1(ϑ)∘q_3(ψ)``, Arribas et al. eq. 12.

Unit quaternions
----------------
Functions that interpret ``q`` as a rotation (:func:`rotate`, :func:`rotate_inverse`,
:func:`to_matrix`, :func:`to_euler`, :func:`to_axis_angle`, :func:`to_rotation_vector`,
:func:`to_mrp`, :func:`to_scipy`, :func:`angle_between`, :func:`slerp`) **reject** a quaternion
whose norm differs from 1 by more than :data:`UNIT_NORM_TOL` (``AttitudeValueError``); they never
renormalise silently. Call :func:`normalize` explicitly first if your quaternion has drifted.
Within the tolerance, the formulas are evaluated with the given ``q`` as is: :func:`rotate` is
literally ``q∘v∘q̃``, which scales lengths by ``|q|²``.

The algebraic functions (:func:`multiply`, :func:`conjugate`, :func:`norm`, :func:`normalize`,
:func:`inverse`, :func:`canonical`) accept any finite quaternion (non-zero where it matters).
"""

from __future__ import annotations

# The functions (``__all__``), and (``X as X``: re-exported) the names the module this package
# replaced imported.
from .._validation import as_float_array as as_float_array
from .._validation import as_quaternion as as_quaternion
from .._validation import as_vector as as_vector
from ..errors import AttitudeTypeError as AttitudeTypeError
from ..errors import AttitudeValueError as AttitudeValueError
from ..errors import SingularityError as SingularityError
from ._algebra import (
    UNIT_NORM_TOL,
    angle_between,
    canonical,
    conjugate,
    inverse,
    multiply,
    norm,
    normalize,
    rotate,
    rotate_inverse,
    slerp,
)
from ._algebra import FloatArray as FloatArray
from ._conversions import (
    EULER_SEQUENCES,
    MATRIX_TOL,
    from_axis_angle,
    from_euler,
    from_matrix,
    from_mrp,
    from_rotation_vector,
    from_scipy,
    to_axis_angle,
    to_euler,
    to_matrix,
    to_mrp,
    to_rotation_vector,
    to_scipy,
)

__all__ = [
    "EULER_SEQUENCES",
    "MATRIX_TOL",
    "UNIT_NORM_TOL",
    "angle_between",
    "canonical",
    "conjugate",
    "from_axis_angle",
    "from_euler",
    "from_matrix",
    "from_mrp",
    "from_rotation_vector",
    "from_scipy",
    "inverse",
    "multiply",
    "norm",
    "normalize",
    "rotate",
    "rotate_inverse",
    "slerp",
    "to_axis_angle",
    "to_euler",
    "to_matrix",
    "to_mrp",
    "to_rotation_vector",
    "to_scipy",
]
