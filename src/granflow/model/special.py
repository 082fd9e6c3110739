"""The scaled exponential-integral kernel: the hot path of every model evaluation.

Eq. 3 of Farain & Bonn needs ``exp(-x) * Ei(x)`` and ``exp(-x) * (Ei(x) - Ei(x0))`` for
dimensionless slips ``x = alpha * slip`` from 1e-12 to beyond 1e8. Written naively with
``scipy.special.expi`` the product overflows for x above about 709, the difference cancels
as x0 approaches x, and each point costs a few hundred nanoseconds. This module evaluates
the scaled forms directly:

* :func:`scaled_ei` -- ``E(x) = exp(-x) Ei(x)`` from piecewise Chebyshev fits, a power
  series for small x, a Taylor series about the zero of Ei and an expansion in 1/x for
  large x (tables generated with mpmath by ``tools/make_kernel_tables.py``);
* :func:`scaled_ei_diff` -- ``D(x, x0) = exp(-x) (Ei(x) - Ei(x0))``, as
  ``E(x) - exp(-(x - x0)) E(x0)`` when x0 is far from x and as a 12-point Gauss-Legendre
  quadrature of ``int_0^h exp(-u) / (x - u) du`` (h = x - x0) when it is close, so that
  neither cancellation nor overflow occurs.

Both agree with 40-digit arithmetic to about 1e-15 relative over x in [1e-12, 1e8]
(the test suite checks 1e-12). The loops are compiled with Numba and cached on disk; a
point costs a few nanoseconds.

Compiled API, for kernels built on this one (:mod:`granflow.model.kernel`): the decorators
:data:`compiled` and :data:`compiled_inline`, and the scalar functions
:func:`scaled_ei_scalar`, :func:`scaled_ei_diff_scalar` and :func:`horner`, callable from
compiled code (and, except the inlined ones, from Python).
"""

import math

import numba
import numpy as np
from llvmlite import ir
from numba.extending import intrinsic

from granflow.model import _ei_tables as _t

__all__ = [
    "compiled",
    "compiled_inline",
    "horner",
    "scaled_ei",
    "scaled_ei_diff",
    "scaled_ei_diff_scalar",
    "scaled_ei_scalar",
]

_SERIES = _t.SERIES[::-1].copy()  # highest power first, for Horner's rule
_ROOT_TAYLOR = _t.ROOT_TAYLOR[::-1].copy()
_MIDDLE = _t.MIDDLE[:, ::-1].copy()
_LARGE = _t.LARGE[::-1].copy()
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(12)
_GL_NODES = 0.5 * (_GL_NODES + 1.0)  # on [0, 1]
_GL_WEIGHTS = 0.5 * _GL_WEIGHTS

#: Compile options for every kernel loop: cached on disk, IEEE arithmetic except that a*b+c may
#: become one fused multiply-add (which is more accurate, not less).
compiled = numba.njit(cache=True, error_model="numpy", nogil=True, fastmath={"contract"})
#: The same for the scalar pieces, inlined into the loops that call them (about 2x faster).
compiled_inline = numba.njit(
    cache=True, error_model="numpy", nogil=True, fastmath={"contract"}, inline="always"
)


@intrinsic
def _float_bits(typingctx, value):
    """The IEEE-754 bit pattern of a float64 as an int64 (a free reinterpretation)."""

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return numba.types.int64(numba.types.float64), codegen


_FRACTION_BITS = 52
_PART_BITS = 4  # 2**4 = 16 parts per octave: the top fraction bits select the part
_REST_BITS = _FRACTION_BITS - _PART_BITS
_REST_SCALE = 2.0 ** (1 - _REST_BITS)  # maps the remaining fraction bits onto [0, 2)
_EXPONENT_OF_HALF = 1022  # biased exponent of 0.5
if _t.PARTS_PER_OCTAVE != 1 << _PART_BITS:
    raise ImportError("granflow._ei_tables does not match special.py: regenerate the tables")


@compiled_inline
def horner(coeffs, x):
    """Polynomial with coefficients highest power first, at x."""
    acc = 0.0
    for c in coeffs:
        acc = acc * x + c
    return acc


@compiled_inline
def scaled_ei_scalar(x):
    """exp(-x) Ei(x) for one x > 0; NaN for x <= 0 or NaN, 0 for +inf."""
    if not x > 0.0:
        return math.nan
    if x < _t.SMALL_LIMIT:
        h = (x - _t.EI_ROOT_HI) - _t.EI_ROOT_LO
        if abs(h) < _t.ROOT_HALF_WIDTH:
            ei = h * horner(_ROOT_TAYLOR, h)
        else:
            ei = _t.EULER_GAMMA + math.log(x) + x * horner(_SERIES, x)
        return math.exp(-x) * ei
    if x < _t.LARGE_LIMIT:
        # x = 2**octave * (0.5 + (part + (t + 1) / 2) / 32): octave, part and t from the bits
        bits = _float_bits(x)
        octave = (bits >> _FRACTION_BITS) - _EXPONENT_OF_HALF
        part = (bits >> _REST_BITS) & ((1 << _PART_BITS) - 1)
        t = (bits & ((1 << _REST_BITS) - 1)) * _REST_SCALE - 1.0
        return horner(_MIDDLE[octave * _t.PARTS_PER_OCTAVE + part], t)
    u = _t.LARGE_LIMIT / x
    return horner(_LARGE, 2.0 * u - 1.0) / x


@compiled_inline
def _close_difference(x, h):
    """exp(-x) (Ei(x) - Ei(x - h)) = int_0^h exp(-u) / (x - u) du for |h| < min(1, x/2).

    12-point Gauss-Legendre: the pole at u = x lies at least three half-widths from the
    interval's centre, so the rule converges to about 1e-18.
    """
    total = 0.0
    for i in range(_GL_NODES.shape[0]):
        u = h * _GL_NODES[i]
        total += _GL_WEIGHTS[i] * math.exp(-u) / (x - u)
    return h * total


@compiled_inline
def scaled_ei_diff_scalar(x, x0, scaled_ei_x0, decay):
    """exp(-x) (Ei(x) - Ei(x0)) for x, x0 > 0.

    Takes ``scaled_ei_x0 = exp(-x0) Ei(x0)`` and ``decay = exp(-(x - x0))`` from the caller,
    which usually needs them anyway. Far apart, the difference of the scaled values loses at
    most a factor 1.6 to cancellation; close together, a quadrature avoids it altogether.
    """
    h = x - x0
    if abs(h) < 1.0 and abs(h) < 0.5 * x:
        return _close_difference(x, h)
    return scaled_ei_scalar(x) - decay * scaled_ei_x0


@compiled
def _scaled_ei_loop(x, out):
    for i in range(x.shape[0]):
        out[i] = scaled_ei_scalar(x[i])


@compiled
def _scaled_ei_diff_loop(x, x0, out):
    for i in range(x.shape[0]):
        out[i] = scaled_ei_diff_scalar(x[i], x0[i], scaled_ei_scalar(x0[i]), math.exp(x0[i] - x[i]))


def _as_float_array(value):
    return np.asarray(value, dtype=np.float64)


def scaled_ei(x):
    """Scaled exponential integral ``exp(-x) * Ei(x)`` for x > 0.

    Parameters
    ----------
    x : float or array_like
        Argument [-]; positive. Zero, negative and NaN entries give NaN, +inf gives 0.

    Returns
    -------
    float or numpy.ndarray
        ``exp(-x) * Ei(x)`` [-], finite for every finite positive x, accurate to about
        1e-15 relative (also next to the zero of Ei at x = 0.3725...).

    Examples
    --------
    >>> from granflow.special import scaled_ei
    >>> round(float(scaled_ei(1.0)), 12)
    0.697174883235
    >>> float(scaled_ei(1e4)) * 1e4  # exp(-x) Ei(x) ~ 1/x for large x
    1.0001000200060025
    """
    array = _as_float_array(x)
    flat = np.ascontiguousarray(array.ravel())
    out = np.empty_like(flat)
    _scaled_ei_loop(flat, out)
    out = out.reshape(array.shape)
    return float(out) if out.ndim == 0 else out


def scaled_ei_diff(x, x0):
    """Scaled difference ``exp(-x) * (Ei(x) - Ei(x0))`` without cancellation or overflow.

    Parameters
    ----------
    x, x0 : float or array_like
        Arguments [-]; positive; broadcast against each other. x0 may exceed x (the
        result is then negative).

    Returns
    -------
    float or numpy.ndarray
        The scaled difference [-]; 0 where x == x0, NaN where an argument is not positive.

    Examples
    --------
    >>> from granflow.special import scaled_ei_diff
    >>> round(float(scaled_ei_diff(2.0, 1.0)), 12)
    0.405562113405
    """
    xb, x0b = np.broadcast_arrays(_as_float_array(x), _as_float_array(x0))
    flat_x = np.ascontiguousarray(xb.ravel())
    flat_x0 = np.ascontiguousarray(x0b.ravel())
    out = np.empty_like(flat_x)
    _scaled_ei_diff_loop(flat_x, flat_x0, out)
    out = out.reshape(xb.shape)
    return float(out) if out.ndim == 0 else out
