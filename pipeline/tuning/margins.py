"""Robustness margins of a loop L(s) = C(s) P(s) with an exact dead time e^(-delay s).

Everything is read from the frequency response of the loop (no Padé approximation), and the
stability of the closed loop 1/(1 + L) is decided by the Nyquist criterion, not assumed.

Nyquist criterion (Åström & Murray, *Feedback Systems*, 2008, Section 9.2, Theorem 9.2;
2nd ed. 2021, Section 10.2): with P open-loop poles in the right half plane and N the net
number of clockwise encirclements of -1 by L(s) as s runs the Nyquist contour, the closed loop
has Z = N + P poles in the right half plane. Here the argument principle is applied to
1 + L(s) along the boundary of the right half plane run counter-clockwise (down the imaginary
axis from +jW to -jW, a small semicircle of radius eps into the right half plane around the
``origin_poles`` poles at s = 0, and the large arc), whose winding number is the same N.
By conjugate symmetry only the upper half (w >= 0 and a quarter of the small semicircle) is
evaluated and its change of argument doubled. The far part of the contour is closed
analytically: beyond the grid |L| stays below 1 (the rational part has settled to a constant
below 1 and |e^(-delay s)| <= 1 in the right half plane), so 1 + L stays in Re > 0 there and
contributes no encirclement. A loop whose high-frequency gain |L(j inf)| is 1 or more (a
proper plant with a large lead times a PI) is unstable: its delay makes infinitely many
closed-loop poles with Re >= 0.

Margins (Åström & Murray 2008, Section 9.3; Skogestad & Postlethwaite, *Multivariable
Feedback Control*, 2nd ed. 2005, Sections 2.4.2-2.4.3):

- gain margin GM = 1 / |L(j w180)| at the phase crossover arg L = -180 deg (mod 360) with the
  smallest such value (a dead time gives many phase crossovers);
- phase margin PM = 180 deg + arg L(j wc) at the gain crossover |L(j wc)| = 1;
- delay margin = PM [rad] / wc (Skogestad & Postlethwaite eq. 2.38), the smallest extra dead
  time that destabilises, minimised over the gain crossovers;
- Ms = max |S(jw)|, S = 1/(1 + L), the inverse of the stability margin s_m = 1/Ms, the
  distance from -1 to the Nyquist curve (Åström & Murray Section 9.3), and Mt = max |T(jw)|,
  T = L/(1 + L), with GM >= Ms/(Ms - 1), PM >= 2 arcsin(1/(2 Ms)) (Skogestad &
  Postlethwaite Section 2.4.3, eqs. 2.42-2.43).

The frequency grid is chosen from ``time_scale`` (a characteristic time of the plant) and
``delay``: logarithmic from 1e-4/ts (ts = max(time_scale, delay)) to where |L(jw)| has
settled for good (to 0 for a strictly proper loop, to |L(j inf)| for a proper one), plus a
linear part in which the delay phase moves by at most 0.1 rad between points. The number of
points stays bounded (at most ~20 000 linear ones). Peaks and crossings found on the grid are
refined with scipy (bounded scalar minimisation, brentq).
"""

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq, minimize_scalar

Loop = Callable[[np.ndarray], np.ndarray]

_SCAN_PER_DECADE = 16    # magnitude scan that finds where |L| settles
_LOG_PER_DECADE = 60     # logarithmic part of the grid
_PHASE_STEP = 0.1        # rad of delay phase between neighbouring points of the linear part
_MAX_LINEAR = 20_000     # bound on the linear part
_SETTLE = 0.01           # |L| within 1 % of (1 - |L(j inf)|) of its limit counts as settled
_MAX_BISECT = 60         # rounds of refinement where arg(1 + L) jumps by more than pi/2
_CANDIDATES = 3          # local peaks / phase crossovers refined with scipy


@dataclass(frozen=True)
class Margins:
    """Robustness margins of one loop; frequencies in rad/s, the delay margin in seconds."""

    stable: bool            # closed loop 1/(1+L) stable (Nyquist, Z = N + P = 0)
    ms: float               # max over w>0 of |1/(1+L(jw))|, math.inf if the loop hits -1
    w_ms: float             # frequency of that peak
    gain_margin: float      # smallest 1/|L(j w180)| over the phase crossovers, or math.inf
    w180: float             # its phase crossover, math.nan when none
    phase_margin: float     # degrees in (-180, 180], smallest over the gain crossovers, or inf
    wc: float               # its gain crossover, math.nan when none
    delay_margin: float     # min PM_rad/wc (PM in [0, 2 pi)), inf without crossover, 0 unstable
    mt: float               # max |L/(1+L)|


def _delay(delay: float) -> float:
    return float(delay) if math.isfinite(delay) and delay > 0 else 0.0


def _plan(delay: float, time_scale: float) -> tuple[float, float, np.ndarray]:
    """ts, the lowest frequency (also the radius of the semicircle round s = 0), the scan."""
    delay = _delay(delay)
    small = float(time_scale) if math.isfinite(time_scale) and time_scale > 0 else 0.0
    ts = max(small, delay) or 1.0
    small = small or ts
    w_lo, w_top = 1e-4 / ts, 1e8 / small
    n = math.ceil(_SCAN_PER_DECADE * math.log10(w_top / w_lo)) + 1
    return ts, w_lo, np.logspace(math.log10(w_lo), math.log10(w_top), n)


def _tail(mag: np.ndarray, scan: np.ndarray, r: np.ndarray | float = _SETTLE
          ) -> tuple[np.ndarray, np.ndarray]:
    """Per row of |L| on the scan: the frequency beyond which |L| stays below ``r`` or within
    1 % of (1 - |L(j inf)|) of |L(j inf)| (either way below 1), and |L(j inf)|."""
    c = mag[:, -1]
    tol = _SETTLE * np.where(c < 1, 1 - c, c)
    r = np.broadcast_to(np.asarray(r, dtype=float), c.shape)
    bad = ~((mag <= r[:, None]) | (np.abs(mag - c[:, None]) <= tol[:, None]))
    n = mag.shape[1]
    last = np.where(bad.any(axis=1), n - 1 - np.argmax(bad[:, ::-1], axis=1), 0)
    return scan[np.minimum(last + 1, n - 1)], c


def _frequencies(ts: float, w_lo: float, w_hi: float, delay: float, spin: bool
                 ) -> np.ndarray:
    """The grid on the positive imaginary axis, w_lo first; ``spin``: |L| settles to a value
    that matters (a proper loop), so the grid goes on for two turns of the delay phase."""
    w_end = max(w_hi, 10.0 / ts)
    if delay > 0 and spin:
        w_end += 4 * math.pi / delay
    n_log = math.ceil(_LOG_PER_DECADE * math.log10(w_end / w_lo)) + 1
    parts = [np.logspace(math.log10(w_lo), math.log10(w_end), n_log)]
    if delay > 0:
        n_lin = min(math.ceil(w_end * delay / _PHASE_STEP), _MAX_LINEAR) + 1
        parts.append(np.linspace(0.0, w_end, n_lin)[1:])
    w = np.unique(np.concatenate(parts))
    w = w[w >= w_lo]
    return w[np.concatenate([[True], np.diff(w) > 1e-9 * w[1:]])]


def _contour(w: np.ndarray, origin_poles: int) -> tuple[np.ndarray, float]:
    """Parameter t of the upper half contour and eps (0 without poles at the origin).

    t in [0, eps) is the quarter semicircle s = eps e^(j pi t/(2 eps)) from s = eps to j eps,
    t >= eps the imaginary axis s = j t; without origin poles t = 0 is s = 0.
    """
    if origin_poles > 0:
        eps = float(w[0])
        return np.concatenate([eps * np.linspace(0, 1, 8 * origin_poles + 1)[:-1], w]), eps
    return np.concatenate([[0.0], w]), 0.0


def _s(t: np.ndarray, eps: float) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    s = 1j * t
    if eps > 0:
        inner = t < eps
        s[inner] = eps * np.exp(0.5j * np.pi * t[inner] / eps)
    return s


def _winding(one_plus_l: Callable[[np.ndarray], np.ndarray], t: np.ndarray, f: np.ndarray
             ) -> tuple[int | None, np.ndarray, np.ndarray]:
    """N, the counter-clockwise winding of 1 + L round 0 along the right-half-plane boundary
    run counter-clockwise (= clockwise encirclements of -1 by the usual Nyquist plot).

    Along t increasing (s from the real axis to jW) the increments of arg(1 + L) are kept
    below pi/2 by bisecting; the contour runs the other way, is closed at jW by the far arc
    (arg from 0 to Arg(1 + L(jW)), as |L| < 1 there) and is doubled by conjugate symmetry.
    None when 1 + L vanishes on the contour (the loop passes through -1).
    """
    for _ in range(_MAX_BISECT):
        if not np.all(np.isfinite(f)) or np.any(f == 0):
            return None, t, f
        d = np.angle(f[1:] * np.conj(f[:-1]))
        bad = np.nonzero(np.abs(d) > np.pi / 2)[0]
        if bad.size == 0:
            return int(round((np.angle(f[-1]) - d.sum()) / np.pi)), t, f
        gap = t[bad + 1] - t[bad]
        if np.any(gap <= 1e-12 * t[bad + 1]):
            return None, t, f
        tm = t[bad] + 0.5 * gap
        t, f = np.insert(t, bad + 1, tm), np.insert(f, bad + 1, one_plus_l(tm))
    return None, t, f


def _minima(fun: Callable[[float], float], x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """The smallest of ``fun`` near the lowest few local minima of its samples ``y`` on ``x``."""
    n = x.size
    inner = np.ones(n, dtype=bool)
    inner[1:] &= y[1:] <= y[:-1]
    inner[:-1] &= y[:-1] <= y[1:]
    idx = np.nonzero(inner)[0]
    idx = idx[np.argsort(y[idx])[:_CANDIDATES]]
    best_x, best_y = float(x[np.argmin(y)]), float(np.min(y))
    for k in idx:
        a, b = float(x[max(k - 1, 0)]), float(x[min(k + 1, n - 1)])
        if b <= a:
            continue
        r = minimize_scalar(lambda u, a=a, b=b: fun(a + u * (b - a)), bounds=(0.0, 1.0),
                            method="bounded", options={"xatol": 1e-10})
        if r.fun < best_y:
            best_x, best_y = a + float(r.x) * (b - a), float(r.fun)
    return best_x, best_y


def _roots(fun: Callable[[float], float], x: np.ndarray, idx: np.ndarray) -> list[float]:
    """brentq of ``fun`` in the grid intervals [x[k], x[k+1]], k in ``idx``."""
    out = []
    for k in idx:
        a, b = float(x[k]), float(x[k + 1])
        try:
            out.append(brentq(fun, a, b, xtol=1e-14 * b, maxiter=200))
        except ValueError:  # no sign change after all (rounding at a grid point)
            continue
    return out


def _sign_changes(y: np.ndarray) -> np.ndarray:
    pos = y > 0
    return np.nonzero(pos[:-1] != pos[1:])[0]


def _wrap_deg(pm: np.ndarray) -> np.ndarray:
    """Degrees wrapped to (-180, 180]."""
    return 180.0 - np.mod(180.0 - pm, 360.0)


def loop_margins(loop: Loop, *, delay: float, time_scale: float, origin_poles: int = 0,
                 rhp_poles: int = 0) -> Margins:
    """Ms, Mt, gain, phase and delay margins and Nyquist stability of one loop.

    ``loop(s)`` maps a complex array of s (any shape) to L(s) including e^(-delay s); it is
    analytic in the closed right half plane but for ``origin_poles`` poles at s = 0, and has
    ``rhp_poles`` poles with Re > 0 (the P of Z = N + P, Åström & Murray 2008 Theorem 9.2).
    ``delay`` (s) and ``time_scale`` (s, the sum of the plant's time constants) set the grid.
    GM, PM (Åström & Murray Section 9.3), Ms, Mt (Skogestad & Postlethwaite Section 2.4.3) and
    the delay margin PM/wc (their eq. 2.38) are refined from the grid with scipy.
    """
    ts, w_lo, scan = _plan(delay, time_scale)
    w_hi, c_inf = _tail(np.abs(loop(1j * scan)).reshape(1, -1), scan)
    c = float(c_inf[0])
    w = _frequencies(ts, w_lo, float(w_hi[0]), _delay(delay), c > _SETTLE)
    t, eps = _contour(w, origin_poles)

    def one_plus_l(tt: np.ndarray) -> np.ndarray:
        return 1.0 + np.asarray(loop(_s(tt, eps)), dtype=complex)

    n_cw, t, f = _winding(one_plus_l, t, one_plus_l(t))
    stable = n_cw is not None and n_cw + rhp_poles == 0 and c < 1

    axis = t >= eps if eps > 0 else t > 0
    wg, lg = t[axis], f[axis] - 1.0

    def at(x: float) -> complex:
        return complex(np.asarray(loop(np.array([1j * x])), dtype=complex).reshape(-1)[0])

    w_ms, g = _minima(lambda x: abs(1.0 + at(x)) ** 2, wg, np.abs(1.0 + lg) ** 2)
    ms = math.inf if n_cw is None or g <= 0 else 1.0 / math.sqrt(g)
    def neg_t(x: float) -> float:
        lx = at(x)
        return -abs(lx) / max(abs(1.0 + lx), 1e-300)

    _, neg_mt = _minima(neg_t, wg,
                        -np.abs(lg) / np.maximum(np.abs(1.0 + lg), 1e-300))

    # phase crossovers: Im L changes sign where Re L < 0; refine the few with the largest |L|
    mag = np.abs(lg)
    sin_arg = lg.imag / np.maximum(mag, 1e-300)
    k180 = _sign_changes(sin_arg)
    k180 = k180[lg.real[k180] + lg.real[k180 + 1] < 0]
    gm, w180 = math.inf, math.nan
    if k180.size:
        k180 = k180[np.argsort(-np.maximum(mag[k180], mag[k180 + 1]))[:_CANDIDATES]]
        for x in _roots(lambda x: math.sin(np.angle(at(x))), wg, k180):
            lx = at(x)
            if lx.real < 0 and 1.0 / abs(lx) < gm:
                gm, w180 = 1.0 / abs(lx), x

    # gain crossovers: log|L| changes sign (|L| does not depend on the delay: a few of them)
    kc = _sign_changes(np.log(np.maximum(mag, 1e-300)))
    wcs = np.array(_roots(lambda x: math.log(max(abs(at(x)), 1e-300)), wg, kc))
    pm, wc, dm = math.inf, math.nan, math.inf
    if wcs.size:
        pms = _wrap_deg(180.0 + np.degrees(np.angle(np.asarray(loop(1j * wcs)))))
        i = int(np.argmin(pms))
        pm, wc = float(pms[i]), float(wcs[i])
        dm = float(np.min(np.mod(np.radians(pms), 2 * np.pi) / wcs))
    if not stable:
        dm = 0.0
    return Margins(stable=bool(stable), ms=float(ms), w_ms=float(w_ms), gain_margin=float(gm),
                   w180=float(w180), phase_margin=pm, wc=wc, delay_margin=dm,
                   mt=float(-neg_mt))


def _closest(x: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Per row of ``f`` = 1 + L (m, n) on ``x`` (n,): min |1 + L|^2 near the grid minimum.

    1 + L is interpolated by the complex quadratic through the grid minimum and its two
    neighbours (it follows the curvature of the Nyquist curve, so a close pass to -1 between
    grid points is found too), then sampled finely in between.
    """
    m, n = f.shape
    r = np.arange(m)
    y = np.abs(f) ** 2
    if n < 3:
        return np.min(y, axis=1)
    k0 = np.argmin(np.where(np.isfinite(y), y, np.inf), axis=1)
    k = np.clip(k0, 1, n - 2)
    x0, x1, x2 = x[k - 1, None], x[k, None], x[k + 1, None]
    f0, f1, f2 = f[r, k - 1, None], f[r, k, None], f[r, k + 1, None]
    u = x0 + (x2 - x0) * np.linspace(0.0, 1.0, 65)
    q = (f0 * (u - x1) * (u - x2) / ((x0 - x1) * (x0 - x2))
         + f1 * (u - x0) * (u - x2) / ((x1 - x0) * (x1 - x2))
         + f2 * (u - x0) * (u - x1) / ((x2 - x0) * (x2 - x1)))
    fine = np.min(np.abs(q) ** 2, axis=1)
    grid = y[r, k0]
    return np.where(np.isfinite(fine), np.minimum(grid, np.maximum(fine, grid / 16)), grid)


def sensitivity_peaks(loops: Loop, *, delay: float, time_scale: float, origin_poles: int = 0,
                      rhp_poles: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Ms and Nyquist stability of a batch of loops on one common frequency grid.

    ``loops(s)`` takes a 1-D complex array s of shape (nw,) and returns L of shape (m, nw), one
    row per parameter set; ``delay`` and ``time_scale`` are the largest over the batch. Returns
    (ms, stable), both of shape (m,). Ms = max |1/(1 + L)| (Skogestad & Postlethwaite 2005,
    Section 2.4.3) from the grid, refined between the points next to its peak;
    stability by Z = N + P (Åström & Murray 2008, Theorem 9.2), the rows whose argument jumps
    on the common grid (a loop passing close to -1) refined one by one as in
    :func:`loop_margins`. The grid first goes to where every |L| stays below 1/2 (past the
    last gain crossover, which is all the criterion needs), then on to where |L| stays below
    1 - 1/Ms, beyond which |S| <= 1/(1 - |L|) cannot exceed the Ms found (within 0.2 %).
    """
    ts, w_lo, scan = _plan(delay, time_scale)
    delay = _delay(delay)
    mag = np.abs(np.asarray(loops(1j * scan)))
    mag = mag.reshape(-1, scan.size)
    c = mag[:, -1]
    c_max = float(np.max(np.where(c < 1, c, 0.0)))
    w = _frequencies(ts, w_lo, float(np.max(_tail(mag, scan, 0.5)[0])), delay, c_max > 0.5)
    t, eps = _contour(w, origin_poles)
    f = 1.0 + np.asarray(loops(_s(t, eps)), dtype=complex).reshape(c.size, t.size)

    finite = np.all(np.isfinite(f), axis=1) & np.all(f != 0, axis=1)
    with np.errstate(invalid="ignore"):
        d = np.angle(f[:, 1:] * np.conj(f[:, :-1]))
    n_cw = np.rint((np.angle(f[:, -1]) - d.sum(axis=1)) / np.pi)
    through = np.zeros(c.size, dtype=bool)
    for i in np.nonzero(~finite | np.any(np.abs(d) > np.pi / 2, axis=1))[0]:
        def one_plus_l(tt: np.ndarray, i: int = i) -> np.ndarray:
            return 1.0 + np.asarray(loops(_s(tt, eps)), dtype=complex)[i]

        wind, _, _ = _winding(one_plus_l, t, f[i])
        through[i] = wind is None
        n_cw[i] = 0 if wind is None else wind
    stable = ~through & (n_cw + rhp_poles == 0) & (c < 1)

    axis = t >= eps if eps > 0 else t > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        g = _closest(t[axis], f[:, axis])
        r = np.clip(1.0 - 1.0 / (1.002 * np.sqrt(1.0 / g)), _SETTLE, 0.5)
    r = np.where(np.isfinite(r), r, 0.5)
    w_hi = float(np.max(_tail(mag, scan, r)[0]))
    if w_hi > w[-1]:  # the rest of the grid, to where |S| can no longer beat the Ms found
        w2 = _frequencies(ts, w_lo, w_hi, delay, bool(np.any((c < 1) & (c > r))))
        w2 = w2[w2 > w[-1]]
        f2 = 1.0 + np.asarray(loops(1j * w2), dtype=complex).reshape(c.size, w2.size)
        with np.errstate(invalid="ignore"):
            g = np.minimum(g, _closest(w2, f2))
    with np.errstate(divide="ignore", invalid="ignore"):
        ms = np.where(through | ~(g > 0), np.inf, 1.0 / np.sqrt(g))
    return ms, stable


__all__ = ["Loop", "Margins", "loop_margins", "sensitivity_peaks"]
