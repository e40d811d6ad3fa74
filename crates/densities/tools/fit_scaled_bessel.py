"""Writes src/scaled_bessel_coefficients.rs: the polynomial pieces of e^(-x) I0(x), e^(-x) I1(x) / x,
e^(-x) (I0(x) - I1(x)) and e^(-2x) (I0(x)^2 - I1(x)^2 - I0(x) I1(x) / x), the last two being the
numerators of 1 - A(x) and A'(x) (A = I1/I0), which cancel when formed from the first two.

Run from crates/densities with `python3 tools/fit_scaled_bessel.py` (needs mpmath). Each piece is the
Chebyshev interpolant at 16 first-kind Chebyshev points, computed in 50-digit arithmetic and converted
to monomials in the piece's local variable xi in [-1, 1] (in x itself on [0, 1/2]), then rounded once to
f64. The pieces are [0, 1/2], [1/2, 1] and the quarter octaves [2^e (1 + j/4), 2^e (1 + (j+1)/4)] for
e = 0..5, j = 0..3 (half octaves left the numerator of A' 1e-13 off on [8, 12]); above 64 the code uses
the Hankel expansion, whose coefficients are written here too. The script prints the worst relative
error of each piece evaluated in f64 by Horner's rule against mpmath at 400 points.
"""
import mpmath as mp

mp.mp.dps = 50
N = 16          # coefficients per piece
TAIL_TERMS = 16  # Hankel terms above x = 64 (as many as the pieces, so one evaluator serves)


def h0(x):
    return mp.exp(-x) * mp.besseli(0, x)


def h1(x):
    return mp.exp(-x) * mp.besseli(1, x) / x if x != 0 else mp.mpf(1) / 2


def d0(x):
    return mp.exp(-x) * (mp.besseli(0, x) - mp.besseli(1, x))


def n0(x):
    """e^(-2x) (I0^2 - I1^2 - I0 I1 / x), the numerator of A'(x) = n0 / h0^2; by its positive series
    (1/2) sum_k (2k)! / (k!^2 (k+1)!^2) (x/2)^(2k) times e^(-2x) near 0, where I1/x is 0/0."""
    if x == 0:
        return mp.mpf(1) / 2
    i0, i1 = mp.besseli(0, x), mp.besseli(1, x)
    return mp.exp(-2 * x) * (i0 * i0 - i1 * i1 - i0 * i1 / x)


def monomial_interpolant(f, a, b):
    return [float(m) for m in monomial_interpolant_exact(f, a, b)]


def monomial_interpolant_exact(f, a, b, n=N):
    pts = [mp.cos(mp.pi * (k + mp.mpf(1) / 2) / n) for k in range(n)]
    vals = [f((b - a) / 2 * xi + (a + b) / 2) for xi in pts]
    cheb = [2 * mp.fsum(vals[k] * mp.cos(j * mp.pi * (k + mp.mpf(1) / 2) / n) for k in range(n)) / n
            for j in range(n)]
    cheb[0] /= 2
    basis = [[mp.mpf(1)], [mp.mpf(0), mp.mpf(1)]]
    for j in range(2, n):
        new = [mp.mpf(0)] * (j + 1)
        for i, v in enumerate(basis[-1]):
            new[i + 1] += 2 * v
        for i, v in enumerate(basis[-2]):
            new[i] -= v
        basis.append(new)
    mono = [mp.mpf(0)] * n
    for j in range(n):
        for i, v in enumerate(basis[j]):
            mono[i] += cheb[j] * v
    return mono


def exact_at_zero_interpolant(f):
    """On [0, 1/2], in x itself: f(0) exactly plus x times the interpolant of (f(x) - f(0)) / x
    (re-expanded from xi = 4x - 1 to x), so that tiny x give f(0) to the last bit."""
    f0 = f(mp.mpf(0))
    mono = monomial_interpolant_exact(lambda x: (f(x) - f0) / x, mp.mpf(0), mp.mpf(1) / 2, N - 1)
    in_x = [mp.fsum(mono[i] * mp.binomial(i, j) * mp.mpf(4) ** j * (-1) ** (i - j)
                    for i in range(j, len(mono))) for j in range(len(mono))]
    return [float(f0)] + [float(v) for v in in_x]


def horner(c, xi):
    r = 0.0
    for v in reversed(c):
        r = r * xi + v
    return r


pieces = [(mp.mpf(0), mp.mpf(1) / 2), (mp.mpf(1) / 2, mp.mpf(1))]
for e in range(6):
    lo = mp.mpf(2) ** e
    pieces += [(lo * (1 + mp.mpf(j) / 4), lo * (1 + mp.mpf(j + 1) / 4)) for j in range(4)]

tables = {}
for name, f in (("I0", h0), ("I1_OVER_X", h1), ("I0_MINUS_I1", d0), ("DERIVATIVE_NUMERATOR", n0)):
    rows = []
    for a, b in pieces:
        c = exact_at_zero_interpolant(f) if a == 0 else monomial_interpolant(f, a, b)
        worst = 0.0
        for k in range(400):
            x = float(a + (b - a) * (k + mp.mpf(1) / 2) / 400)
            xi = x if a == 0 else (2 * x - float(a) - float(b)) / float(b - a)
            exact = f(mp.mpf(x))
            worst = max(worst, float(abs((horner(c, xi) - exact) / exact)))
        print(f"{name} on [{float(a)}, {float(b)}]: worst relative error {worst:.2e}")
        rows.append(c)
    tables[name] = rows


def hankel(nu, terms=TAIL_TERMS):
    """Exact rationals, so that differences of them are exact before rounding."""
    out, term = [], mp.mpf(1)
    for k in range(terms):
        out.append(term)
        term *= -(4 * nu * nu - (2 * k + 1) ** 2) / (8 * (k + 1))
    return out


def derivative_numerator_hankel():
    """2 pi x e^(-2x) (I0^2 - I1^2 - I0 I1 / x) = P0^2 - P1^2 - y P0 P1 in powers of y = 1/x, with
    P_nu the Hankel sums: exact rationals whose y^0 and y^1 terms cancel; returned from y^2 on."""
    p0, p1 = hankel(0, TAIL_TERMS + 2), hankel(1, TAIL_TERMS + 2)
    out = []
    for m in range(2, TAIL_TERMS + 2):
        c = mp.fsum(p0[i] * p0[m - i] - p1[i] * p1[m - i] for i in range(m + 1))
        c -= mp.fsum(p0[i] * p1[m - 1 - i] for i in range(m))
        out.append(c)
    return out


def check_tail():
    """Worst relative error of the Hankel forms at and above 64, where the code uses them."""
    worst_d, worst_n = 0.0, 0.0
    for x in [64, 65, 70, 80, 100, 150, 300, 1000, 1e4, 1e6]:
        x = mp.mpf(x)
        y = 1 / x
        scale = 1 / mp.sqrt(2 * mp.pi * x)
        d = scale * mp.fsum(float(a - b) * y ** k for k, (a, b) in enumerate(zip(hankel(0), hankel(1))))
        n = y * y * mp.fsum(float(c) * y ** k for k, c in enumerate(derivative_numerator_hankel())) / (2 * mp.pi * x)
        worst_d = max(worst_d, float(abs(d / d0(x) - 1)))
        worst_n = max(worst_n, float(abs(n / n0(x) - 1)))
    print(f"Hankel tails from 64: 1 - A numerator {worst_d:.2e}, A' numerator {worst_n:.2e}")


check_tail()

with open("src/scaled_bessel_coefficients.rs", "w") as fh:
    fh.write("//! Generated by `tools/fit_scaled_bessel.py`; do not edit.\n\n")
    fh.write("#![allow(clippy::unreadable_literal, clippy::excessive_precision)]\n\n")
    for name, rows in tables.items():
        what = {"I0": "e^(-x) I0(x)", "I1_OVER_X": "e^(-x) I1(x) / x",
                "I0_MINUS_I1": "e^(-x) (I0(x) - I1(x))",
                "DERIVATIVE_NUMERATOR": "e^(-2x) (I0(x)^2 - I1(x)^2 - I0(x) I1(x) / x)"}[name]
        fh.write(f"/// Monomial coefficients in the local variable of each piece, of {what}.\n")
        fh.write(f"pub(crate) const {name}: [[f64; {N}]; {len(rows)}] = [\n")
        for row in rows:
            fh.write("    [" + ", ".join(repr(v) for v in row) + "],\n")
        fh.write("];\n\n")
    fh.write("/// Hankel coefficients of sqrt(2 pi x) e^(-x) I0(x) in powers of 1/x.\n")
    fh.write(f"pub(crate) const HANKEL_0: [f64; {TAIL_TERMS}] = [" +
             ", ".join(repr(float(v)) for v in hankel(0)) + "];\n")
    fh.write("/// The same for sqrt(2 pi x) e^(-x) (I0(x) - I1(x)), differenced exactly (its leading 1 cancels).\n")
    fh.write(f"pub(crate) const HANKEL_0_MINUS_1: [f64; {TAIL_TERMS}] = [" +
             ", ".join(repr(float(a - b)) for a, b in zip(hankel(0), hankel(1))) + "];\n")
    fh.write("/// 2 pi x e^(-2x) (I0(x)^2 - I1(x)^2 - I0(x) I1(x) / x) = P0^2 - P1^2 - P0 P1 / x (P the Hankel\n")
    fh.write("/// sums) in powers of y = 1/x from y^2 on: its y^0 and y^1 terms cancel exactly.\n")
    fh.write(f"pub(crate) const HANKEL_DERIVATIVE_NUMERATOR: [f64; {TAIL_TERMS}] = [" +
             ", ".join(repr(float(v)) for v in derivative_numerator_hankel()) + "];\n")
