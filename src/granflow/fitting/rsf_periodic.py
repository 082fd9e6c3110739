"""Apparatus periodicity in load-point displacement: its term in a fit, and its periodogram.

A screw-driven load point (or a gear, a bearing) can leave a ripple in the friction that
repeats with the load-point position, not with time: ``harmonics`` Fourier terms of one
wavelength lambda,

    sum over h of  cos_h cos(2 pi h d / lambda) + sin_h sin(2 pi h d / lambda),

with d the load-point displacement since the protocol's start [m]. At two velocities the same
ripple has periods a decade apart in time and one wavelength in displacement, which is how it
tells itself from friction physics. :func:`periodic_terms` evaluates it and its Jacobian;
:func:`displacement_periodogram` finds it in a fit's residuals (a generalised Lomb-Scargle
periodogram against displacement, harmonics included); :func:`periodicity_check` says whether
the residuals hold a significant one, allowing for their correlation and for the number of
wavelengths searched.
"""

import math

import numpy as np
from scipy import optimize, stats

__all__ = [
    "best_wavelength",
    "displacement_periodogram",
    "fit_amplitudes",
    "harmonic_names",
    "periodic_terms",
    "periodicity_check",
    "wavelength_range",
]

#: Frequency grid of the periodogram: points per resolution width 1 / span.
_OVERSAMPLE = 5
#: At most this many trial wavelengths (the shortest searched rises where more would be needed).
_MAX_TRIALS = 2000
#: A component counts as significant below this false-alarm probability.
FALSE_ALARM = 1e-3
#: Grid points the comparison band of a peak must hold on its long-wavelength side.
_SIDE = 10
#: The band keeps this many resolution widths 1 / span away from the peak.
_GAP = 2.0
_CHUNK = 64  # wavelengths per block of the periodogram (memory: points x chunk x columns)


def harmonic_names(harmonics):
    """The amplitude names of ``harmonics`` harmonics: ``cos1, sin1, cos2, sin2, ...``."""
    return tuple(f"{kind}{h}" for h in range(1, harmonics + 1) for kind in ("cos", "sin"))


def _columns(position, wavelength, harmonics):
    phase = 2.0 * math.pi * np.asarray(position, dtype=float) / wavelength
    return np.column_stack(
        [f(h * phase) for h in range(1, harmonics + 1) for f in (np.cos, np.sin)]
    )


def periodic_terms(position, wavelength, amplitudes, with_jacobian=False):
    """The periodic friction term [-] at load-point displacements ``position`` [m].

    Parameters
    ----------
    position : array_like
        Load-point displacement since the protocol's start [m].
    wavelength : float
        The wavelength in displacement [m].
    amplitudes : sequence of float
        ``cos1, sin1, cos2, sin2, ...`` [-] (:func:`harmonic_names`).
    with_jacobian : bool
        Also return d term / d (wavelength, cos1, sin1, ...), shape (n, 1 + len(amplitudes)).

    Returns
    -------
    numpy.ndarray or (numpy.ndarray, numpy.ndarray)
    """
    amplitudes = np.asarray(amplitudes, dtype=float)
    columns = _columns(position, wavelength, amplitudes.size // 2)
    term = columns @ amplitudes
    if not with_jacobian:
        return term
    # d/d lambda of c cos(h phi) + s sin(h phi), phi = 2 pi d / lambda: h phi / lambda times
    # (c sin(h phi) - s cos(h phi))
    phase = 2.0 * math.pi * np.asarray(position, dtype=float) / wavelength
    d_wavelength = np.zeros(term.shape)
    for h in range(1, amplitudes.size // 2 + 1):
        c, s = amplitudes[2 * h - 2], amplitudes[2 * h - 1]
        d_wavelength += (
            h * phase / wavelength * (c * columns[:, 2 * h - 1] - s * columns[:, 2 * h - 2])
        )
    return term, np.column_stack([d_wavelength, columns])


def wavelength_range(position, scatter_points=25, cycles=3.0):
    """(shortest, longest) wavelength [m] a periodogram of these points searches: at least
    ``scatter_points`` samples per period everywhere (a shorter ripple is part of the
    high-frequency scatter, :func:`granflow.fitting.rsf_forward.noise_scatter`) and at least
    ``cycles`` periods over the displacement covered."""
    position = np.asarray(position, dtype=float)
    span = float(np.ptp(position))
    # the spacing of the fastest sliding (a percentile: a glitch of one sample does not count)
    spacing = float(np.percentile(np.abs(np.diff(position)), 99)) if position.size > 1 else 0.0
    return max(scatter_points * spacing, 1e-300), span / cycles


def _normal_equations(sums, moments, harmonics):
    """J^T J and J^T y of the columns 1, cos phi, sin phi, cos 2 phi, ... per wavelength, from
    ``sums[k]`` = sum of exp(i k phi) (k = 0 .. 2H) and ``moments[h]`` = sum of
    y exp(i h phi) (h = 0 .. H)."""

    def cc(h, g):  # sum of cos(h phi) cos(g phi)
        return 0.5 * (sums[h + g].real + sums[abs(h - g)].real)

    def ss(h, g):
        return 0.5 * (sums[abs(h - g)].real - sums[h + g].real)

    def sc(h, g):  # sum of sin(h phi) cos(g phi)
        return 0.5 * (sums[h + g].imag + np.sign(h - g) * sums[abs(h - g)].imag)

    size = 1 + 2 * harmonics
    gram = np.empty((sums.shape[1], size, size))
    moment = np.zeros((sums.shape[1], size))
    for i in range(size):
        hi, si = (i + 1) // 2, i % 2 == 0 and i > 0
        for j in range(size):
            hj, sj = (j + 1) // 2, j % 2 == 0 and j > 0
            if si and sj:
                gram[:, i, j] = ss(hi, hj)
            elif si:
                gram[:, i, j] = sc(hi, hj)
            elif sj:
                gram[:, i, j] = sc(hj, hi)
            else:
                gram[:, i, j] = cc(hi, hj)
        if i:
            moment[:, i] = moments[hi].imag if si else moments[hi].real
    return gram, moment


def _reduction(position, residuals, wavelengths, harmonics, uniform=False):
    """Sum of squares removed by a constant plus the harmonics at each wavelength.

    ``uniform``: the wavelengths are uniform in 1 / lambda, so that exp(i phi) at one is
    that at the one before times a fixed factor per point (a product, not an exponential).

    The normal equations need only the sums of cos(k phi) and sin(k phi), k = 1 .. 2H, over
    the points, and those of y cos(h phi), y sin(h phi) (products of harmonics are sums of
    harmonics): one complex exponential per point and wavelength, its powers, and two matrix
    products per block of wavelengths.
    """
    y = residuals - residuals.mean()
    n = y.size
    size = 1 + 2 * harmonics
    total = np.empty(len(wavelengths))
    step = None
    if uniform and len(wavelengths) > 1:
        step = np.exp(2j * math.pi * position * (1.0 / wavelengths[1] - 1.0 / wavelengths[0]))
    for start in range(0, len(wavelengths), _CHUNK):
        block = np.asarray(wavelengths[start : start + _CHUNK], dtype=float)
        if step is None:
            unit = np.exp(2j * math.pi * position[None, :] / block[:, None])  # (chunk, n)
        else:
            unit = np.empty((block.size, n), dtype=complex)
            unit[0] = np.exp(2j * math.pi * position / block[0])
            for j in range(1, block.size):
                np.multiply(unit[j - 1], step, out=unit[j])
        power = np.ones_like(unit)
        # sums[k] = sum of exp(i k phi), k = 0 .. 2H; moments[h] = sum of y exp(i h phi)
        sums = [np.full(block.size, complex(n))]
        moments = [np.zeros(block.size, dtype=complex)]
        for k in range(1, 2 * harmonics + 1):
            power = power * unit
            sums.append(power.sum(axis=1))
            if k <= harmonics:
                # real and imaginary parts apart: a complex matrix-vector product takes
                # a hundred times longer in some BLAS builds
                moments.append(power.real @ y + 1j * (power.imag @ y))
        sums = np.array(sums)  # (2H + 1, chunk)

        gram, moment = _normal_equations(sums, moments, harmonics)
        ridge = 1e-12 * n * np.eye(size)
        solved = np.linalg.solve(gram + ridge, moment[:, :, None])[:, :, 0]
        total[start : start + block.size] = np.einsum("wi,wi->w", solved, moment)
    return total


def displacement_periodogram(position, residuals, harmonics=2, wavelengths=None):
    """The periodogram of residuals against load-point displacement.

    For each trial wavelength, the fraction of the residuals' variance (about their mean)
    that a least-squares fit of ``harmonics`` harmonics removes (the generalised
    Lomb-Scargle periodogram, on an irregular grid of displacement).

    Parameters
    ----------
    position : array_like
        Load-point displacement [m] of each residual.
    residuals : array_like
        Fit residuals [-].
    harmonics : int
        Harmonics fitted at each wavelength.
    wavelengths : array_like, optional
        Trial wavelengths [m]; default: uniform in 1 / lambda over
        :func:`wavelength_range`, five per resolution width 1 / span, at most 2000 (from the
        longest down).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        The wavelengths [m] and the fraction of variance removed at each.
    """
    position = np.asarray(position, dtype=float)
    residuals = np.asarray(residuals, dtype=float)
    uniform = wavelengths is None
    if wavelengths is None:
        shortest, longest = wavelength_range(position)
        span = float(np.ptp(position))
        if not longest > shortest:
            return np.empty(0), np.empty(0)
        step = 1.0 / (_OVERSAMPLE * span)
        highest = min(1.0 / shortest, 1.0 / longest + _MAX_TRIALS * step)
        frequencies = np.arange(1.0 / longest, highest, step)
        wavelengths = 1.0 / frequencies
    wavelengths = np.asarray(wavelengths, dtype=float)
    variance = float(np.sum((residuals - residuals.mean()) ** 2))
    if not variance > 0:
        return wavelengths, np.zeros(wavelengths.size)
    removed = _reduction(position, residuals, wavelengths, harmonics, uniform=uniform)
    return wavelengths, removed / variance


def _refine(position, residuals, wavelengths, power, harmonics):
    """The wavelength [m] of the highest peak of a periodogram, refined between its grid
    neighbours."""
    i = int(np.clip(np.argmax(power), 1, power.size - 2))
    lo, hi = sorted((1.0 / wavelengths[i - 1], 1.0 / wavelengths[i + 1]))
    found = optimize.minimize_scalar(
        lambda f: -_reduction(position, residuals, [1.0 / f], harmonics)[0],
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-4 * (hi - lo)},
    )
    return float(1.0 / found.x)


def best_wavelength(position, residuals, harmonics=2):
    """The wavelength [m] of the periodogram's highest peak, refined between its grid
    neighbours; None where the displacement covers too little for three periods."""
    position = np.asarray(position, dtype=float)
    residuals = np.asarray(residuals, dtype=float)
    wavelengths, power = displacement_periodogram(position, residuals, harmonics)
    if power.size < 3:
        return None
    return _refine(position, residuals, wavelengths, power, harmonics)


def fit_amplitudes(position, residuals, wavelength, harmonics):
    """Least-squares amplitudes ``cos1, sin1, ...`` [-] of the harmonics in ``residuals``
    (about their mean)."""
    columns = _columns(position, wavelength, harmonics)
    design = np.column_stack([np.ones(len(residuals)), columns])
    solution, *_ = np.linalg.lstsq(design, np.asarray(residuals, dtype=float), rcond=None)
    return solution[1:]


def _sides(frequency, centre, span):
    """The comparison band of a peak at ``centre`` [1/m] in the sorted ``frequency`` grid:
    (below, above) index ranges of the grid points from half to twice ``centre``, at least
    two resolution widths 1 / span away from it."""
    lo = np.searchsorted(frequency, 0.5 * centre, side="right")
    below = np.searchsorted(frequency, centre - _GAP / span, side="left")
    above = np.searchsorted(frequency, centre + _GAP / span, side="right")
    hi = np.searchsorted(frequency, 2.0 * centre, side="left")
    return (lo, below), (above, hi)


def _background(frequency, power, centre, span):
    """The noise's power at ``centre`` [1/m] from the band around it: the median of each
    side, a power law through the two (a red spectrum falls steeply: one side's median
    misses it by a factor); only the side below where the grid ends above (a falling
    spectrum's side, so the estimate errs high). None where the side below holds fewer
    than :data:`_SIDE` points. Returns (level, grid points it comes from) or None."""
    (b0, b1), (a0, a1) = _sides(frequency, centre, span)
    if b1 - b0 < _SIDE:
        return None
    f_below, p_below = np.median(frequency[b0:b1]), np.median(power[b0:b1])
    if a1 - a0 < _SIDE:
        return float(p_below), b1 - b0
    f_above, p_above = np.median(frequency[a0:a1]), np.median(power[a0:a1])
    if not (p_below > 0 and p_above > 0):
        return float(max(p_below, p_above)), b1 - b0 + a1 - a0
    slope = math.log(p_above / p_below) / math.log(f_above / f_below)
    return float(p_below * (centre / f_below) ** slope), b1 - b0 + a1 - a0


def periodicity_check(position, residuals, harmonics=2):
    """Whether fit residuals hold a ripple periodic in load-point displacement.

    The highest peak of :func:`displacement_periodogram` is tested against the periodogram
    around it (wavelengths from half to twice the peak's, two resolution widths 1 / span
    away from it). For noise, white or red, the power at one wavelength is the spectrum's
    local level times chi-square with ``2 harmonics`` degrees of freedom over their count.
    The level at the peak is a power law through the medians of the band's two sides (a red
    spectrum is steep: the median of the whole band, most of it at shorter wavelengths,
    would miss it low); it is itself a noisy estimate (about one independent value per
    resolution width), so the peak over it, scaled by the median of the chi-square, is taken
    as F-distributed, which gives the probability of so high a peak at one wavelength; over
    the number of independent wavelengths searched it becomes a false-alarm probability.
    Only wavelengths with at least :data:`_SIDE` grid points of the band on the long side
    are searched: next to the longest wavelength (three periods over the span) the level
    would be an extrapolation from the short side alone, and red noise fakes ripples there.

    Parameters
    ----------
    position : array_like
        Load-point displacement [m] of each residual.
    residuals : array_like
        Fit residuals [-].
    harmonics : int
        Harmonics at the trial wavelength.

    Returns
    -------
    dict
        ``wavelength`` [m], ``amplitude`` [-] (half the peak-to-peak of the fitted ripple),
        ``rms`` [-] (its root mean square), ``fraction`` (of the residual variance it
        removes), ``false_alarm`` (probability), ``significant`` (false alarm below
        :data:`FALSE_ALARM`); an empty dict where the displacement covers too little for
        the search (three periods of a wavelength the sampling resolves, with a band on
        its long side), or the residuals are not finite.
    """
    position = np.asarray(position, dtype=float)
    residuals = np.asarray(residuals, dtype=float)
    if not (np.all(np.isfinite(residuals)) and np.all(np.isfinite(position))):
        return {}
    wavelengths, power = displacement_periodogram(position, residuals, harmonics)
    span = float(np.ptp(position))
    frequency = 1.0 / wavelengths  # increasing
    # the band's long side fills up with the frequency: the first that holds enough on
    searched = [_background(frequency, power, f, span) is not None for f in frequency]
    first = searched.index(True) if True in searched else frequency.size
    if frequency.size - first < 3:
        return {}
    wavelength = _refine(position, residuals, wavelengths[first:], power[first:], harmonics)
    amplitudes = fit_amplitudes(position, residuals, wavelength, harmonics)
    ripple = periodic_terms(position, wavelength, amplitudes)
    ripple = ripple - ripple.mean()
    centred = residuals - residuals.mean()
    variance = float(centred @ centred)
    peak = float(_reduction(position, residuals, [wavelength], harmonics)[0]) / variance
    background = _background(frequency, power, 1.0 / wavelength, span)
    dof = 2 * harmonics
    if background is not None and background[0] > 0:
        # the level is itself noisy (a few independent values: one per resolution width):
        # the peak over it is F-distributed, not chi-square
        ratio = peak / background[0] * stats.chi2.median(dof) / dof
        single = float(stats.f.sf(ratio, dof, dof * background[1] / _OVERSAMPLE))
    else:
        single = 1.0
    # independent wavelengths searched: the frequency range over the resolution width
    trials = max(span * (frequency[-1] - frequency[first]), 1.0)
    false_alarm = float(-np.expm1(trials * np.log1p(-min(single, 1.0 - 1e-16))))
    return {
        "wavelength": wavelength,
        "amplitude": float(0.5 * np.ptp(ripple)),
        "rms": float(np.sqrt(np.mean(ripple**2))),
        "fraction": peak,
        "false_alarm": false_alarm,
        "significant": bool(false_alarm < FALSE_ALARM),
    }
