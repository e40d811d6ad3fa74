"""Reference values of the Bingham normaliser on S^3 and its gradient (the second moments along the
eigenvectors) at eigenvalue spreads from 1e3 to 1e12, for `tests/bingham.rs`.

ln K(z) = ln E_{q ~ uniform(S^3)}[exp(sum_k z_k q_k^2)] by the one-dimensional Bessel form for the
pairing {z0, z2}, {z1, z3} of the eigenvalues as given (the library sorts them and pairs {0, 1},
{2, 3}, so the two integrands differ), in mpmath at 60 digits, with mpmath's own adaptive
tanh-sinh quadrature and the interval split at t = c/spread and 1 - c/spread for c = 1, 4, 16, ...
(the boundary layers' widths). The second moments E[q_k^2] = d ln K / d z_k come from central
differences with step 1e-20 (1 + spread), whose truncation and rounding errors are below 1e-30
relative; their sum is checked against 1. Run: `python3 crates/densities/tools/
bingham_spread_reference.py > crates/densities/tests/data/bingham_spread.json` (a few minutes).
"""
import json
import sys

import mpmath as mp

mp.mp.dps = 60


def log_k(z):
    z = [mp.mpf(v) for v in z]
    (za, zb), (zc, zd) = (z[0], z[2]), (z[1], z[3])
    top = max(z)
    spread = top - min(z)

    def integrand(t):
        u = 1 - t
        return (mp.exp(t * (za + zb) / 2 + u * (zc + zd) / 2 - top)
                * mp.besseli(0, t * (za - zb) / 2) * mp.besseli(0, u * (zc - zd) / 2))

    breaks = {mp.mpf(0), mp.mpf(1)}
    if spread > 200:
        c = mp.mpf(1)
        while c < spread / 4:
            breaks |= {c / spread, 1 - c / spread}
            c *= 4
    breaks = sorted(b for b in breaks if 0 <= b <= 1)
    return top + mp.log(mp.quad(integrand, breaks))


def case(z):
    spread = max(z) - min(z)
    h = mp.mpf("1e-20") * (1 + mp.mpf(spread))
    value = log_k(z)
    moments = []
    for k in range(4):
        up = [mp.mpf(v) for v in z]
        down = [mp.mpf(v) for v in z]
        up[k] += h
        down[k] -= h
        moments.append((log_k(up) - log_k(down)) / (2 * h))
    return {
        "z": z,
        "spread": spread,
        "log_normalizer": mp.nstr(value, 25),
        "moments": [mp.nstr(m, 25) for m in moments],
        "moment_sum_minus_one": float(abs(sum(moments) - 1)),
    }


def shapes(s):
    return [
        [0.0, -s, -s, -s],
        [0.0, 0.0, 0.0, -s],
        [0.0, 0.0, -s, -s],
        [0.0, -s / 3, -2 * s / 3, -s],
        [0.0, -1.0, -s / 2, -s],
        [0.0, -s * 1e-3, -s * 1e-3 - 1.0, -s],
        [0.0, -0.37 * s, -0.61 * s, -s],
    ]


if __name__ == "__main__":
    cases = []
    for s in [1e3, 1e6, 1e9, 1e12]:
        for z in shapes(s):
            c = case(z)
            print(z, c["log_normalizer"][:22], c["moment_sum_minus_one"], file=sys.stderr, flush=True)
            cases.append(c)
    json.dump({
        "description": (
            "Bingham on S^3 (uniform probability measure): for eigenvalues z (as given, unsorted "
            "allowed), log_normalizer = ln E_uniform[exp(sum z_k q_k^2)] and moments[k] = E[q_k^2] "
            "= d ln K / d z_k. Made by crates/densities/tools/bingham_spread_reference.py: the "
            "Bessel form for the pairing {z0, z2}, {z1, z3}, mpmath 60 digits, moments by central "
            "differences; strings hold 25 significant digits."
        ),
        "cases": cases,
    }, sys.stdout, indent=1)
