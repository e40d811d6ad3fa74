"""Reference values of the Bingham normaliser on S^3 and its second moments at eigenvalue spreads 1 to
1e12, in mpmath (60 significant digits working precision).

Conventions: z = (0, l1, l2, l3) with l_i <= 0 (the largest eigenvalue is 0),
    K(z) = E_{q ~ uniform(S^3)}[exp(sum_i z_i q_i^2)],  logK_unif = ln K,
    second_moments[i] = E_Bingham[q_i^2] = d ln K / d z_i  (i = 0 the axis of eigenvalue 0).
Internally lam_i = -z_i >= 0 are sorted ascending (lam_1 = 0 <= lam_2 <= lam_3 <= lam_4) and
    E(lam) = K = E_Dir[exp(-sum lam_i x_i)],   x = (q_i^2) ~ Dirichlet(1/2, 1/2, 1/2, 1/2),
    M_j(lam) = E_Dir[x_j exp(-sum lam_i x_i)] = -dE/dlam_j,   second moment j = M_j / E.
Every M_j is computed by its own integral or series (analytic differentiation, no finite differences),
so |sum_j M_j / E - 1| is a genuine check.

Methods (each returns E and the four M_j; a case is computed by every method that applies):

 T  Inverse Laplace transform on a Talbot contour.  The Gaussian integral over R^4 in polar
    coordinates gives  int_0^inf e^(-t rho) rho F(rho) drho = 2 pi^2 prod_i (t + lam_i)^(-1/2)  with
    F(rho) = int_{S^3} exp(-rho sum lam_i u_i^2) dS, hence
        E = (1/(2 pi i)) int_C e^t prod_i (t + lam_i)^(-1/2) dt,
        M_j = (1/(2 pi i)) int_C e^t (1/2) (t + lam_j)^(-1) prod_i (t + lam_i)^(-1/2) dt,
    C: t(th) = r th (cot th + i), -pi < th < pi (r = 6), which encloses the whole cut (-inf, 0]; ties
    are harmless (they only merge branch points into poles inside C).  The integral is
    (1/pi) int_0^pi Im(...) dth, evaluated by composite Gauss-Legendre (64 nodes per panel) on
    panels graded towards th = pi, truncated where Re t < -(prec ln 2 + 60).
 B  The same transform with the contour collapsed onto the cut (real-axis "branch-cut" form):
        E = (1/pi) [P(lam1, lam2; lam3, lam4) - P(lam3, lam4; lam1, lam2)],
        P(a, b; c, d) = 2 int_0^(pi/2) e^(-s) |(s - c)(s - d)|^(-1/2) dth,  s = a + (b - a) sin^2 th,
    with the derivatives of P in a, b, c, d taken analytically under the integral sign. Not used
    when lam2 = lam3 (both pieces then diverge logarithmically; the tie cases have closed forms).
 S  Power series (for lam4 <= 2e4): with c = lam4 and mu_i = c - lam_i >= 0,
        E = e^(-c) sum_n g_n / (2)_n,   sum_n g_n u^n = prod_i (1 - mu_i u)^(-1/2),
        M_j = e^(-c) sum_n g^(j)_n / (2 (2)_(n+1)), the same with exponent -3/2 on factor j,
    all terms positive (no cancellation); g_n by the recurrence (order <= 3) that follows from
    the first-order ODE  Q(u) G'(u) = R(u) G(u),  Q = prod (1 - mu_i u).
 L  Laplace expansion in the large eigenvalues (lam_i >= 500 for all i in the large set Lg): with
    the small set Sm = the others (the mode axis, plus possibly one more), integrate exactly over
    Sm and extend the integral over the Lg coordinates from the simplex to the orthant
    (error O(e^(-min_Lg lam/4)), below 1e-50 relative here):
      Sm = {mode} (or all-zero eigenvalues): E = C pi^(|Lg|/2-2) prod_Lg lam^(-1/2) sum_k (-alpha)_k e_k,
          e_k = [u^k] prod_Lg (1 - u/lam_i)^(-1/2), alpha = |Sm|/2 - 1; an asymptotic series whose
          truncation error is at most twice the first omitted term (all terms of one sign, the
          remainder of the binomial series bounded by its first term on y <= 1/2), and the series is
          stopped only when that is below 1e-52 relative.
      Sm = {mode, one eigenvalue b}: E = pi^(|Lg|/2-2) 2 int_0^(pi/2) e^(-b sin^2 a)
          prod_Lg (lam_i - b sin^2 a)^(-1/2) da  (exact up to the orthant extension).
 C  Closed forms for the tie patterns (0,s,s,s), (0,0,0,s), (0,0,s,s):
      (0,s,s,s): y = 1 - x1 ~ Beta(3/2,1/2): E = 1F1(3/2;2;-s), M_1 = 1F1(3/2;3;-s)/4,
                 M_2 = M_3 = M_4 = 1F1(5/2;3;-s)/4;
      (0,0,0,s): x4 ~ Beta(1/2,3/2): E = 1F1(1/2;2;-s), M_4 = 1F1(3/2;3;-s)/4,
                 M_1 = M_2 = M_3 = 1F1(1/2;3;-s)/4;
      (0,0,s,s): x3 + x4 ~ U(0,1): E = (1 - e^(-s))/s, M_3 = M_4 = (1 - e^(-s)(1+s))/(2 s^2),
                 M_1 = M_2 = (s - 1 + e^(-s))/(2 s^2).
    (1F1 by mpmath's hyp1f1.)
 T2 is T again with r = 5 and 96 nodes per panel (T: 64), as an estimate of T's own quadrature error.

The stored value is from T; "agreement" is the largest relative difference between T and any other
applicable method over ln K (absolute / max(1, |ln K|)) and the four moments (relative).

Usage (from the repository root, mpmath 1.3; the output path does not depend on the working directory):
    python3 crates/densities/tools/bingham_spread_reference.py
        writes crates/reference/data/bingham_spread_vectors.json (about 25 s on one core); refuses to
        write if any case disagrees beyond 1e-30 or its moments do not sum to 1 within 1e-25.
        With --out PATH it writes PATH instead (to compare a regeneration with the stored file).
    python3 crates/densities/tools/bingham_spread_reference.py --check-old crates/reference/data/bingham_vectors.json
        compares the 28 cases of that (independently computed, f64) file with this computation.
"""
import json
import sys
import time

import mpmath as mp
from mpmath import mpf

DPS = 60
mp.mp.dps = DPS

# ---------------------------------------------------------------- composite Gauss-Legendre
_GL = {}


def gl_nodes(n):
    key = (n, mp.mp.prec)
    if key not in _GL:
        X, W = mp.gauss_quadrature(n, "legendre")
        _GL[key] = (X, W)
    return _GL[key]


def vquad(f, pts, n):
    """Vector-valued composite Gauss-Legendre of degree n on the panels given by pts."""
    X, W = gl_nodes(n)
    tot = None
    for a, b in zip(pts[:-1], pts[1:]):
        h = (b - a) / 2
        m = (a + b) / 2
        for x, w in zip(X, W):
            v = f(m + h * x)
            wh = w * h
            if tot is None:
                tot = [wh * vi for vi in v]
            else:
                for i in range(len(v)):
                    tot[i] += wh * v[i]
    return tot


# ---------------------------------------------------------------- T: Talbot contour
TALBOT_R = mpf(6)


def method_T(lam, n=64, r=TALBOT_R):
    pi = mp.pi
    # Panels on (0, pi): [0, pi/4, pi/2, 3pi/4] then graded towards pi until e^(Re t) is negligible.
    pts = [mpf(0), pi / 8, pi / 4, 3 * pi / 8, pi / 2, 5 * pi / 8, 3 * pi / 4]
    d = pi / 4
    cut = mp.mp.prec * mp.log(2) + 60  # e^(-cut) far below the working precision
    while True:
        d /= 2
        th = pi - d
        pts.append(th)
        if r * th * mp.cot(th) < -cut:
            break

    def f(th):
        ct = mp.cot(th)
        t = r * th * mp.mpc(ct, 1)
        dt = r * mp.mpc(ct - th / mp.sin(th) ** 2, 1)
        F = mp.exp(t) * dt
        for l in lam:
            F /= mp.sqrt(t + l)
        out = [F.imag]
        for l in lam:
            out.append((F / (2 * (t + l))).imag)
        return out

    v = vquad(f, pts, n)
    return [x / pi for x in v]


# ---------------------------------------------------------------- B: branch cut on the real axis
CUT = mpf(330)  # e^-330 ~ 1e-143


def bc_piece(a, b, c, d, n):
    """[P, dP/da, dP/db, dP/dc, dP/dd] for P(a,b;c,d) = 2 int_0^(pi/2) e^-s |(s-c)(s-d)|^-1/2 dth."""
    w = b - a
    if w == 0:
        s = a
        f = mp.pi * mp.exp(-s) / mp.sqrt((s - c) * (s - d))
        fs = f * (-1 - 1 / (2 * (s - c)) - 1 / (2 * (s - d)))
        return [f, fs / 2, fs / 2, f / (2 * (s - c)), f / (2 * (s - d))]
    half = mp.pi / 2
    tmax = half if w <= CUT else mp.asin(mp.sqrt(CUT / w))
    gap_a = min(abs(a - c), abs(a - d))
    gap_b = min(abs(b - c), abs(b - d))
    sc0 = min(mpf(1), 1 / mp.sqrt(w), mp.sqrt(gap_a / w))
    pts = {mpf(0), tmax}
    x = sc0 / 8
    while x < tmax:
        pts.add(x)
        x *= 2
    if tmax == half:
        sc1 = min(mpf(1), mp.sqrt(gap_b / w))
        y = sc1 / 8
        while y < half:
            pts.add(half - y)
            y *= 2
    pts = sorted(pts)

    def f(th):
        sn2 = mp.sin(th) ** 2
        cs2 = 1 - sn2
        s = a + w * sn2
        sc = s - c
        sd = s - d
        g = 2 * mp.exp(-s) / mp.sqrt(sc * sd)
        gs = g * (-1 - 1 / (2 * sc) - 1 / (2 * sd))
        return [g, gs * cs2, gs * sn2, g / (2 * sc), g / (2 * sd)]

    return vquad(f, pts, n)


def method_B(lam, n=60):
    l1, l2, l3, l4 = lam
    if l2 == l3:
        return None
    p = bc_piece(l1, l2, l3, l4, n)
    q = bc_piece(l3, l4, l1, l2, n)
    pi = mp.pi
    E = (p[0] - q[0]) / pi
    M = [-(p[1] - q[3]) / pi, -(p[2] - q[4]) / pi, -(p[3] - q[1]) / pi, -(p[4] - q[2]) / pi]
    return [E] + M


# ---------------------------------------------------------------- S: positive power series
def _series_sum(mu, A, denom_shift):
    """sum_n g_n / (2)_(n + denom_shift), sum_n g_n u^n = prod (1 - mu_i u)^(-A_i)."""
    groups = {}
    for m, a in zip(mu, A):
        if m != 0:
            groups[m] = groups.get(m, 0) + a
    nus = list(groups)
    # Q(u) = prod (1 - nu u); R(u) = sum_nu A_nu nu prod_{nu' != nu} (1 - nu' u)
    Q = [mpf(1)]
    for nu in nus:
        Q = [(Q[i] if i < len(Q) else 0) - (nu * Q[i - 1] if i >= 1 else 0) for i in range(len(Q) + 1)]
    R = [mpf(0)] * max(1, len(nus))
    for nu in nus:
        P = [mpf(groups[nu]) * nu]
        for nu2 in nus:
            if nu2 != nu:
                P = [(P[i] if i < len(P) else 0) - (nu2 * P[i - 1] if i >= 1 else 0) for i in range(len(P) + 1)]
        for i, v in enumerate(P):
            R[i] += v
    if not nus:
        return 1 / mp.factorial(denom_shift + 1)
    numax = max(nus)
    g = [mpf(1)]
    # (2)_(k) = (k+1)!; denominator for term n: (2)_(n+shift) = (n+shift+1)!
    den = mp.factorial(denom_shift + 1)
    total = g[0] / den
    prev = total
    eps = mpf(10) ** (-(mp.mp.dps + 5))
    n = 0
    while True:
        # g_{n+1}
        acc = mpf(0)
        for j, rj in enumerate(R):
            if n - j >= 0:
                acc += rj * g[n - j]
        for j in range(1, len(Q)):
            k = n + 1 - j
            if k >= 0:
                acc -= Q[j] * k * g[k]
        g.append(acc / (n + 1))
        n += 1
        den *= n + denom_shift + 1
        term = g[n] / den
        total += term
        if n > numax + 2 and term > 0 and prev > 0:
            ratio = term / prev
            if ratio < 1 and term / (1 - ratio) < eps * total:
                break
        prev = term
        if n > 10 * numax + 1000:
            raise RuntimeError("series did not converge")
    return total


def method_S(lam, max_lam=2e4):
    c = max(lam)
    if c > max_lam:
        return None
    mu = [c - l for l in lam]
    ec = mp.exp(-c)
    out = [ec * _series_sum(mu, [mpf(1) / 2] * 4, 0)]
    for j in range(4):
        A = [mpf(1) / 2] * 4
        A[j] = mpf(3) / 2
        out.append(ec * _series_sum(mu, A, 1) / 2)
    return out


# ---------------------------------------------------------------- L: Laplace expansion
LAPLACE_MIN = 500


def _poly_coeffs(lams_exps, K):
    """[u^k] prod (1 - u/lam)^(-A), k = 0..K."""
    c = [mpf(1)] + [mpf(0)] * K
    for lam, A in lams_exps:
        b = [mpf(1)]
        for k in range(1, K + 1):
            b.append(b[-1] * (A + k - 1) / (k * lam))
        c = [sum(c[i] * b[k - i] for i in range(k + 1)) for k in range(K + 1)]
    return c


def method_L(lam):
    large = [i for i in range(4) if lam[i] >= LAPLACE_MIN]
    small = [i for i in range(4) if lam[i] < LAPLACE_MIN]
    if not large or 0 not in small:
        return None
    lmin = min(lam[i] for i in large)
    pi = mp.pi
    nl = len(large)
    pre = pi ** (mpf(nl) / 2 - 2)
    for i in large:
        pre /= mp.sqrt(lam[i])
    small_l = [lam[i] for i in small]
    if all(v == 0 for v in small_l):
        p = len(small)
        alpha_E = mpf(p) / 2 - 1
        C_E = pi ** (mpf(p) / 2) / mp.gamma(mpf(p) / 2)
        alpha_S = mpf(p) / 2
        C_S = pi ** (mpf(p - 1) / 2) * mp.gamma(mpf(3) / 2) / mp.gamma(mpf(p) / 2 + 1)
        tol = mpf(10) ** -52

        def asym(alpha, exps):
            # sum_k (-alpha)_k e_k, stopped at the first term below tol |sum|; for y <= 1/2 the
            # binomial remainder is at most twice its first term, so the error is <= 2 |that term|.
            K = 16
            while K <= 512:
                e = _poly_coeffs(exps, K)
                total = mpf(0)
                poch = mpf(1)
                for k in range(K + 1):
                    term = poch * e[k]
                    if term == 0:
                        return total, mpf(0)
                    if k > 0 and abs(term) < tol * abs(total):
                        return total, 2 * abs(term) / abs(total)
                    total += term
                    poch *= -alpha + k
                K *= 2
            raise RuntimeError("Laplace series does not reach tolerance")

        base = [(lam[i], mpf(1) / 2) for i in large]
        sE, errE = asym(alpha_E, base)
        E = pre * C_E * sE
        M = [None] * 4
        errs = [errE]
        for j in range(4):
            if j in small:
                s, er = asym(alpha_S, base)
                M[j] = pre * C_S * s
            else:
                exps = [(lam[i], mpf(3) / 2 if i == j else mpf(1) / 2) for i in large]
                s, er = asym(alpha_E, exps)
                M[j] = pre * C_E * s / (2 * lam[j])
            errs.append(er)
        if max(errs) > mpf(10) ** -35:
            return None
        return [E] + M
    if len(small) == 2:
        b = small_l[1]
        jb = small[1]
        if b * 10 > lmin:
            return None

        def f(a):
            sn2 = mp.sin(a) ** 2
            beta = b * sn2
            g = 2 * mp.exp(-beta)
            for i in large:
                g /= mp.sqrt(lam[i] - beta)
            corr = 1 - sum(1 / (2 * (lam[i] - beta)) for i in large)
            out = [g, g * (1 - sn2) * corr, g * sn2 * corr]
            for i in large:
                out.append(g / (2 * (lam[i] - beta)))
            return out

        v = vquad(f, [mpf(0), pi / 8, pi / 4, 3 * pi / 8, pi / 2], 40)
        v = [x * pi ** (mpf(nl) / 2 - 2) for x in v]
        M = [None] * 4
        M[0] = v[1]
        M[jb] = v[2]
        for k, i in enumerate(large):
            M[i] = v[3 + k]
        return [v[0]] + M
    return None


# ---------------------------------------------------------------- C: closed forms for tie patterns
def method_C(lam):
    l1, l2, l3, l4 = lam
    h = mp.hyp1f1
    q = mpf(1) / 4
    if l1 == 0 and l2 == l3 == l4 and l2 > 0:
        s = l2
        E = h(1.5, 2, -s)
        return [E, q * h(1.5, 3, -s)] + [q * h(2.5, 3, -s)] * 3
    if l1 == l2 == l3 == 0 and l4 > 0:
        s = l4
        E = h(0.5, 2, -s)
        return [E] + [q * h(0.5, 3, -s)] * 3 + [q * h(1.5, 3, -s)]
    if l1 == l2 == 0 and l3 == l4 and l3 > 0:
        s = l3
        em = mp.exp(-s)
        E = -mp.expm1(-s) / s
        m3 = (1 - em * (1 + s)) / (2 * s * s)
        m1 = (s - 1 + em) / (2 * s * s)
        return [E, m1, m1, m3, m3]
    return None


# ---------------------------------------------------------------- driver
def to_out(v):
    """[E, M1..M4] -> (ln E, moments)."""
    E = v[0]
    return mp.log(E), [m / E for m in v[1:]]


def rel_diff(a, b):
    la, ma = a
    lb, mb = b
    d = abs(la - lb) / max(1, abs(la))
    for x, y in zip(ma, mb):
        d = max(d, abs(x - y) / abs(y))
    return d


METHODS = {
    "T": method_T,
    "T2": lambda lam: method_T(lam, n=96, r=mpf(5)),
    "B": method_B,
    "S": method_S,
    "L": method_L,
    "C": method_C,
}


def compute(zs, methods=("T", "T2", "B", "S", "L", "C")):
    """zs = (l1, l2, l3) <= 0.  Returns dict of method -> (lnK, moments in the original order)."""
    z = [mpf(0)] + [mpf(v) for v in zs]
    lam_orig = [-v for v in z]
    perm = sorted(range(4), key=lambda i: lam_orig[i])
    lam = [lam_orig[i] for i in perm]
    res = {}
    timing = {}
    for name in methods:
        t0 = time.time()
        v = METHODS[name](lam)
        timing[name] = time.time() - t0
        if v is None:
            continue
        lnE, m_sorted = to_out(v)
        m = [None] * 4
        for k, i in enumerate(perm):
            m[i] = m_sorted[k]
        res[name] = (lnE, m)
    return res, timing


def cases(with_spread=False):
    out = []
    for s in [1.0, 10.0, 1e3, 1e6, 1e8, 1e9, 1e10, 1e12]:
        out += [(s, zs) for zs in [
            (-s, -s, -s),  # one large gap, then equal (a tight axis-symmetric Bingham)
            (0.0, 0.0, -s),  # equal top three, one small direction
            (0.0, -s, -s),  # equal pairs
            (-s / 3, -2 * s / 3, -s),  # three equal large gaps
            (-1.0, -s / 2, -s),  # a unit gap then two large ones
            (-s * 1e-3, -s * 1e-3 - 1.0, -s),  # two close middle eigenvalues
            (-0.37 * s, -0.61 * s, -s),  # generic
        ]]
    return out if with_spread else [zs for _, zs in out]


def describe():
    return (
        "Bingham on S^3 at eigenvalue spreads 1 to 1e12: z = (0, l1, l2, l3) with (l1, l2, l3) = lambdas "
        "(all <= 0, the largest eigenvalue is 0; seven shapes per spread, ties included); spread = max z - min z. logK_unif = ln E_{q~uniform(S^3)}"
        "[exp(sum_i z_i q_i^2)] (uniform probability measure on S^3; add ln(2 pi^2) for the raw surface "
        "integral). second_moments[i] = E_Bingham[q_i^2] = d logK_unif / d z_i for i = 0 (the axis of "
        "eigenvalue 0), 1, 2, 3 (the axes of l1, l2, l3); they sum to 1. Strings hold 30 significant digits. "
        "Computed in mpmath at 60 digits by crates/densities/tools/bingham_spread_reference.py, independently of the library "
        "and without its Bessel-integral form. Stored values: the inverse Laplace transform "
        "E = (1/(2 pi i)) int e^t prod_i (t - z_i)^(-1/2) dt on a Talbot contour enclosing the whole cut, the "
        "unnormalised moments E[q_j^2 e^(z.q^2)] as the same integral with the extra factor (1/2)(t - z_j)^(-1) "
        "(analytic differentiation, no finite differences; ties between eigenvalues need no special care). "
        "Cross-checks, each case by every one that applies: the same transform collapsed onto the branch cut "
        "(real-axis integrals, derivatives under the integral sign; not where the two middle eigenvalues tie); "
        "the positive power series of the Dirichlet(1/2,1/2,1/2,1/2) moments (spreads <= 1e3); the Laplace "
        "expansion in the eigenvalues <= -500 (all cases at spreads >= 1e6, some at 1e3; truncation error "
        "provably below 1e-50 relative, the other directions integrated exactly); closed forms by 1F1 / elementary functions for the tie "
        "patterns (0,s,s,s), (0,0,0,s), (0,0,s,s). agreement = largest relative difference between the stored "
        "values and any cross-check (ln K absolute / max(1, |ln K|), each moment relative); methods lists the "
        "cross-checks used (B branch cut, S power series, L Laplace expansion, C closed form); every case has "
        "at least two, and all agree with the stored values to better than 1e-52. "
        "|sum of moments - 1| < 1e-57 for every case; a second Talbot contour (r = 5, 96 nodes per panel) "
        "agrees with the stored values to better than 1e-57. Against the 28 cases of bingham_vectors.json "
        "(spreads <= 1e4, stored as f64) the largest difference is 7.9e-17 on ln K and 1.0e-16 on the "
        "moments, the double rounding of that file."
    )


def summarise(res):
    ref = res["T"]
    agree = max((rel_diff(v, ref) for k, v in res.items() if k not in ("T", "T2")), default=None)
    internal = rel_diff(res["T2"], ref)
    return ref, agree, internal


def check_old(path):
    old = json.load(open(path))
    worst_l = worst_m = mpf(0)
    for c in old["cases"]:
        res, _ = compute(c["lambdas"])
        ref, agree, internal = summarise(res)
        ln0 = mpf(c["logK_unif"])
        el = abs(ref[0] - ln0) / max(1, abs(ln0))
        em = max(abs(x / mpf(y) - 1) for x, y in zip(ref[1], c["second_moments"]))
        worst_l = max(worst_l, el)
        worst_m = max(worst_m, em)
        print(c["lambdas"], "dlnK %.1e dmom %.1e" % (el, em), "methods", "".join(k for k in res if k != "T2"),
              "agreement %.1e internal %.1e" % (agree, internal), flush=True)
    print("worst |d lnK|/max(1,|lnK|) %.2e, worst relative moment difference %.2e" % (worst_l, worst_m))


def main():
    if "--check-old" in sys.argv:
        check_old(sys.argv[-1])
        return
    import os
    here = os.path.dirname(os.path.abspath(__file__))
    out_path = os.path.join(here, "..", "..", "reference", "data", "bingham_spread_vectors.json")
    if "--out" in sys.argv:
        out_path = sys.argv[sys.argv.index("--out") + 1]
    t0 = time.time()
    rows = []
    per_spread = {}
    worst_sum = mpf(0)
    for nominal, zs in cases(with_spread=True):
        res, tm = compute(zs)
        ref, agree, internal = summarise(res)
        msum = abs(sum(ref[1]) - 1)
        worst_sum = max(worst_sum, msum)
        if agree is None or agree > mpf(10) ** -30 or internal > mpf(10) ** -30 or msum > mpf(10) ** -25:
            raise RuntimeError("case %s not trustworthy: agreement %s internal %s sum %s" % (zs, agree, internal, msum))
        spread = -min(zs)  # max z - min z (1.001 for the close-middle shape at nominal spread 1)
        ps = per_spread.setdefault(nominal, [mpf(0), mpf(0), mpf(0)])
        ps[0] = max(ps[0], agree)
        ps[1] = max(ps[1], internal)
        ps[2] = max(ps[2], msum)
        methods = [k for k in res if k not in ("T", "T2")]
        print(zs, mp.nstr(ref[0], 20), "methods", "".join(methods), "agreement %.1e internal %.1e sum %.1e"
              % (agree, internal, msum), "%.2fs" % sum(tm.values()), file=sys.stderr, flush=True)
        rows.append({
            "lambdas": [float(v) for v in zs],
            "spread": float(spread),
            "logK_unif": mp.nstr(ref[0], 30, strip_zeros=False),
            "second_moments": [mp.nstr(v, 30, strip_zeros=False) for v in ref[1]],
            "agreement": float(mp.mpf(mp.nstr(agree, 3))),
            "methods": methods,
        })
    for s, (a, i, m) in per_spread.items():
        print("nominal spread %g: worst agreement %.1e, T internal %.1e, worst |sum-1| %.1e" % (s, a, i, m), file=sys.stderr)
    print("worst |sum of moments - 1| %.1e; %.1f s" % (worst_sum, time.time() - t0), file=sys.stderr)
    doc = {"description": describe(), "cases": rows}
    with open(out_path, "w") as fh:
        json.dump(doc, fh, indent=1)
        fh.write("\n")


if __name__ == "__main__":
    main()
