#!/usr/bin/env python3
"""Fit the basis spectra of vitrum's RGB-to-spectrum upsampling (src/spectrum.rs, `basis`).

The basis is B = softmax(r(x), 0, b(x)) with r and b cubics in x = (λ − 580 nm) / 200 nm, so
B_r + B_g + B_b = 1 and 0 < B_c < 1 by construction. The eight coefficients are fitted
(Levenberg–Marquardt, numerical Jacobian) so that ∫ B_c(λ) w_c'(λ) dλ = δ_cc' over 380–780 nm,
where w is the colour weight of monochromatic light that `rgb_weight` computes: the CIE 1931 2°
colour-matching functions (Wyman–Sloan–Shirley multi-lobe fit), XYZ → linear sRGB (D65), scaled
per channel to unit integral. Only the red and blue rows are free: the green row follows from
the partition of unity and ∫ w_c' = 1. Six residuals, eight unknowns: the start point (a red
that rises and a blue that falls across the range) picks the smooth solution.

Pure Python, no dependencies. Prints the coefficients for BASIS_RED and BASIS_BLUE:
    python3 scripts/spectral/fit_basis.py
"""
import math

LAMBDA_MIN, LAMBDA_MAX = 380.0, 780.0
XYZ_TO_SRGB = [[3.2404542, -1.5371385, -0.4985314],
               [-0.9692660, 1.8760108, 0.0415560],
               [0.0556434, -0.2040259, 1.0572252]]


def lobe(l, mu, inv_below, inv_above):
    t = (l - mu) * (inv_below if l < mu else inv_above)
    return math.exp(-0.5 * t * t)


def cie_xyz(l):
    x = (1.056 * lobe(l, 599.8, 0.0264, 0.0323) + 0.362 * lobe(l, 442.0, 0.0624, 0.0374)
         - 0.065 * lobe(l, 501.1, 0.0490, 0.0382))
    y = 0.821 * lobe(l, 568.8, 0.0213, 0.0247) + 0.286 * lobe(l, 530.9, 0.0613, 0.0322)
    z = 1.217 * lobe(l, 437.0, 0.0845, 0.0278) + 0.681 * lobe(l, 459.0, 0.0385, 0.0725)
    return (x, y, z)


def srgb(l):
    xyz = cie_xyz(l)
    return [sum(XYZ_TO_SRGB[r][k] * xyz[k] for k in range(3)) for r in range(3)]


# Trapezoidal quadrature on a 0.25 nm grid (the fit of the multi-lobe curves is smooth enough).
STEP = 0.25
GRID = [LAMBDA_MIN + i * STEP for i in range(int((LAMBDA_MAX - LAMBDA_MIN) / STEP) + 1)]
WEIGHTS = [STEP * (0.5 if i in (0, len(GRID) - 1) else 1.0) for i in range(len(GRID))]
_raw = [srgb(l) for l in GRID]
_integral = [sum(w * v[c] for w, v in zip(WEIGHTS, _raw)) for c in range(3)]
W = [[v[c] / _integral[c] for c in range(3)] for v in _raw]
XS = [(l - 580.0) / 200.0 for l in GRID]


def basis(p):
    out = []
    for x in XS:
        r = p[0] + x * (p[1] + x * (p[2] + x * p[3]))
        b = p[4] + x * (p[5] + x * (p[6] + x * p[7]))
        m = max(r, b, 0.0)
        er, eg, eb = math.exp(r - m), math.exp(-m), math.exp(b - m)
        s = er + eg + eb
        out.append((er / s, eg / s, eb / s))
    return out


def residuals(p):
    bs = basis(p)
    return [sum(w * bj[c] * wj[k] for w, bj, wj in zip(WEIGHTS, bs, W)) - (1.0 if c == k else 0.0)
            for c in (0, 2) for k in range(3)]


def solve(a, g):
    n = len(g)
    m = [row[:] + [g[i]] for i, row in enumerate(a)]
    for i in range(n):
        piv = max(range(i, n), key=lambda k: abs(m[k][i]))
        m[i], m[piv] = m[piv], m[i]
        for k in range(n):
            if k != i:
                f = m[k][i] / m[i][i]
                for j in range(i, n + 1):
                    m[k][j] -= f * m[i][j]
    return [m[i][n] / m[i][i] for i in range(n)]


def fit(p, iterations=400):
    damping = 1e-3
    for _ in range(iterations):
        r = residuals(p)
        e = sum(x * x for x in r)
        if e < 1e-14:
            break
        jac = []
        for k in range(len(p)):
            q = p[:]
            q[k] += 1e-6
            jac.append([(a - b) / 1e-6 for a, b in zip(residuals(q), r)])
        n = len(p)
        a = [[sum(jac[i][t] * jac[j][t] for t in range(len(r))) + (damping if i == j else 0.0)
              for j in range(n)] for i in range(n)]
        g = [-sum(jac[i][t] * r[t] for t in range(len(r))) for i in range(n)]
        step = solve(a, g)
        q = [x + d for x, d in zip(p, step)]
        if sum(x * x for x in residuals(q)) < e:
            p, damping = q, max(damping / 3.0, 1e-9)
        else:
            damping *= 5.0
    return p


if __name__ == "__main__":
    # Start: red rising towards long wavelengths, blue towards short ones.
    start = [-2.0, 30.0, 50.0, 0.0, -4.0, 0.0, 15.0, -15.0]
    p = fit(start)
    print("residuals", ["%.2e" % x for x in residuals(p)])
    print("BASIS_RED  =", [float("%.8g" % x) for x in p[:4]])
    print("BASIS_BLUE =", [float("%.8g" % x) for x in p[4:]])
