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

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numba
import numpy as np
from llvmlite import ir
from numba.extending import intrinsic

from granflow.model import _ei_tables as _t

if TYPE_CHECKING:
    from granflow._typing import ArrayLike, FloatOrArray

__all__ = [
    "compiled",
    "compiled_inline",
    "horner",
    "scaled_ei",
    "scaled_ei_diff",
    "scaled_ei_diff_scalar",
    "scaled_ei_piece",
    "scaled_ei_scalar",
    "scaled_ei_simd",
    "simd_exp",
    "simd_log",
    "simd_log1p",
]

_SERIES = _t.SERIES[::-1].copy()  # highest power first, for Horner's rule
_ROOT_TAYLOR = _t.ROOT_TAYLOR[::-1].copy()
_MIDDLE = _t.MIDDLE[:, ::-1].copy()
_LARGE = _t.LARGE[::-1].copy()
#: The middle parts and the large-x fit in one table (the same degree), so that one indexed
#: polynomial serves both regions without a branch.
_TABLE = np.vstack([_t.MIDDLE, _t.LARGE[None, :]])[:, ::-1].copy()
_LARGE_ROW = _t.MIDDLE.shape[0]
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


@intrinsic
def _bits_float(typingctx, bits):
    """The float64 whose IEEE-754 bit pattern is the int64 ``bits`` (a free reinterpretation)."""

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return numba.types.float64(numba.types.int64), codegen


_FRACTION_BITS = 52
_PART_BITS = 4  # 2**4 = 16 parts per octave: the top fraction bits select the part
_REST_BITS = _FRACTION_BITS - _PART_BITS
_REST_SCALE = 2.0 ** (1 - _REST_BITS)  # maps the remaining fraction bits onto [0, 2)
_EXPONENT_OF_HALF = 1022  # biased exponent of 0.5
if _t.PARTS_PER_OCTAVE != 1 << _PART_BITS:
    raise ImportError("granflow._ei_tables does not match special.py: regenerate the tables")


# exp and log without branches or library calls, so that loops over them compile to SIMD code
# (Numba's math.exp and math.log are scalar calls); both agree with the C library to 1 ulp.
_LOG2E = 1.4426950408889634
_LN2_HI = 6.93147180369123816490e-01  # ln 2 in two parts: n * _LN2_HI is exact for |n| < 2**11
_LN2_LO = 1.90821492927058770002e-10
_SHIFTER = 6755399441055744.0  # 1.5 * 2**52: adding it rounds to an integer kept in the low bits
_EXP_TAYLOR = np.array([1.0 / math.factorial(k) for k in range(13, -1, -1)])  # |r| <= ln2 / 2
_ATANH_ODD = np.array([2.0 / (2 * k + 1) for k in range(12, -1, -1)])  # 2 atanh(f) / f in f^2
_SQRT2 = math.sqrt(2.0)


@compiled_inline
def simd_exp(x):
    """exp(x) for any x (0 below -708, the value at 709 above): branch-free, vectorisable.

    ``x = n ln2 + r`` with |r| <= ln2 / 2 (Cody-Waite), a degree-13 Taylor polynomial of
    exp(r) (truncation 5e-18 relative) and 2**n built from its bits.
    """
    clipped = min(max(x, -708.0), 709.0)
    shifted = clipped * _LOG2E + _SHIFTER
    n = shifted - _SHIFTER
    r = (clipped - n * _LN2_HI) - n * _LN2_LO
    acc = 0.0
    for k in range(_EXP_TAYLOR.shape[0]):
        acc = acc * r + _EXP_TAYLOR[k]
    power = _bits_float((_float_bits(shifted) + 1023) << _FRACTION_BITS)
    return acc * power if x >= -708.0 else 0.0


@compiled_inline
def simd_log(x):
    """log(x) for a normal positive x: branch-free, vectorisable.

    ``x = 2**e m`` with m in [sqrt(1/2), sqrt(2)); log m = 2 atanh(f), f = (m - 1)/(m + 1),
    |f| < 0.172, as an odd series of 13 terms (truncation 1e-19 relative).
    """
    bits = _float_bits(x)
    exponent = (bits >> _FRACTION_BITS) - 1023
    mantissa = _bits_float((bits & ((1 << _FRACTION_BITS) - 1)) | (1023 << _FRACTION_BITS))
    high = mantissa > _SQRT2
    mantissa = 0.5 * mantissa if high else mantissa
    e = float(exponent + 1) if high else float(exponent)
    f = (mantissa - 1.0) / (mantissa + 1.0)
    f2 = f * f
    acc = 0.0
    for k in range(_ATANH_ODD.shape[0]):
        acc = acc * f2 + _ATANH_ODD[k]
    return e * _LN2_HI + (f * acc + e * _LN2_LO)


@compiled_inline
def simd_log1p(x):
    """log(1 + x) for x > -1 to full relative precision (also for tiny x): branch-free.

    With u = 1 + x rounded, ``log(u) x / (u - 1)`` corrects the rounding of u (Goldberg 1991).
    """
    u = 1.0 + x
    correction = x / (u - 1.0) if u != 1.0 else 1.0
    return simd_log(u) * correction if u != 1.0 else x


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
def scaled_ei_piece(x):
    """(row of the polynomial table, its argument t in [-1, 1]) for exp(-x) Ei(x) at x >= 0.5.

    Branch-free; the row grows with x (the middle parts in order, then the large-x fit).
    """
    bits = _float_bits(x)
    large = x >= _t.LARGE_LIMIT
    row = min(max((bits >> _REST_BITS) - (_EXPONENT_OF_HALF << _PART_BITS), 0), _LARGE_ROW - 1)
    t_middle = (bits & ((1 << _REST_BITS) - 1)) * _REST_SCALE - 1.0
    return (_LARGE_ROW if large else row), (2.0 * _t.LARGE_LIMIT / x - 1.0 if large else t_middle)


@compiled_inline
def scaled_ei_simd(x, row, t):
    """exp(-x) Ei(x) for x >= 0.5 (garbage below) from :func:`scaled_ei_piece`'s row and t.

    The same polynomials as :func:`scaled_ei_scalar`; the row and the argument are selected,
    not branched on, so that a loop over it compiles to SIMD code (and to SIMD code without
    gathers where every x shares one row).
    """
    acc = 0.0
    for k in range(_TABLE.shape[1]):
        acc = acc * t + _TABLE[row, k]
    return acc / x if row == _LARGE_ROW else acc


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


def scaled_ei(x: ArrayLike) -> FloatOrArray:
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


def scaled_ei_diff(x: ArrayLike, x0: ArrayLike) -> FloatOrArray:
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
