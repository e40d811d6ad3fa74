"""Writes tests/data/density_reference.json: log densities, entropies and KL divergences of the
density families at 50 digits, for the accuracy tests of tests/accuracy.rs.

Run from crates/densities with `python3 tools/reference_densities.py` (needs mpmath; a few minutes).
Every number is written as a string holding the shortest decimal that rounds to its f64 (Python's
repr), which the test parses with Rust's correctly rounded `str::parse` (JSON number parsers need not
round correctly). Every input is an f64, and every value is the exact function of those inputs rounded
once to f64:

* von Mises with mean 0 at offsets d: kappa cos d - ln(2 pi I0(kappa)); entropy
  ln(2 pi I0) - kappa A; KL between two von Mises with means 0 and delta.
* von Mises-Fisher with mean z at the point (sin t, 0, cos t) (coordinates rounded to f64, as the test
  builds them): ln(kappa / (4 pi sinh kappa)) + kappa (1 - |x - mu|^2 / 2) with the f64 coordinates
  (kappa mu . x for a unit x); entropy; KL between means z and z or x.
* Generalised von Mises of order 2: ln Z by adaptive quadrature split at the maxima.
* Bingham with eigenvalues z (orientation the identity) at exactly unit quaternions: sum z_k q_k^2 -
  ln K, K from the one-dimensional representation with the pairing {0, 2}, {1, 3} (the library pairs
  {0, 1}, {2, 3}, so the two integrands differ).
* Heat kernel on SO(3) at rotation angle t: the Poisson-summed form with images |m| <= 12 for s < 1, the
  character series to convergence for s >= 1 (the two agree at s = 0.5 and 1, checked here).
* Gaussian N(mu, sigma^2 I) on R^3 at points x.
"""
import json
import mpmath as mp

mp.mp.dps = 50
PI = mp.pi


def f(x):
    return float(x)


def log_i0(k):
    k = mp.mpf(k)
    return mp.log(mp.besseli(0, k)) if k > 0 else mp.mpf(0)


def a1(k):
    k = mp.mpf(k)
    return mp.besseli(1, k) / mp.besseli(0, k) if k > 0 else mp.mpf(0)


KAPPAS = [0.0, 1e-300, 1e-8, 0.1, 1.0, 10.0, 63.9, 64.0, 100.0, 800.0, 2000.0, 1e4, 1e5, 1e6]
OFFSETS = [0.0, 1e-8, 1e-3, 0.1, 0.5, 2.0, 3.0]

von_mises, vm_entropy, vm_kl = [], [], []
for k in KAPPAS:
    km = mp.mpf(k)
    z = mp.log(2 * PI) + log_i0(km)
    for d in OFFSETS:
        von_mises.append({"kappa": k, "d": d, "log_pdf": f(km * mp.cos(mp.mpf(d)) - z)})
    vm_entropy.append({"kappa": k, "entropy": f(z - km * a1(km))})
for kp in [1e-3, 1.0, 10.0, 800.0, 1e6]:
    for kq in [0.5, 10.0, 1000.0, 1e6]:
        for delta in [0.0, 0.3]:
            kpm, kqm, dm = mp.mpf(kp), mp.mpf(kq), mp.mpf(delta)
            kl = a1(kpm) * (kpm - kqm * mp.cos(dm)) - log_i0(kpm) + log_i0(kqm)
            vm_kl.append({"kappa_p": kp, "kappa_q": kq, "delta": delta, "kl": f(kl)})


def vmf_log_c(k):
    k = mp.mpf(k)
    return mp.log(k / (4 * PI * mp.sinh(k))) if k > 0 else -mp.log(4 * PI)


def vmf_a(k):
    k = mp.mpf(k)
    return mp.coth(k) - 1 / k if k > 0 else mp.mpf(0)


vmf, vmf_entropy, vmf_kl = [], [], []
for k in KAPPAS:
    for t in OFFSETS:
        x = [mp.mpf(float(mp.sin(t))), mp.mpf(0), mp.mpf(float(mp.cos(t)))]
        gap = x[0] ** 2 + x[1] ** 2 + (x[2] - 1) ** 2
        vmf.append({"kappa": k, "t": t, "x": [f(v) for v in x],
                    "log_pdf": f(vmf_log_c(k) + mp.mpf(k) * (1 - gap / 2))})
    vmf_entropy.append({"kappa": k, "entropy": f(-vmf_log_c(k) - mp.mpf(k) * vmf_a(k))})
for kp in [1e-3, 1.0, 10.0, 2000.0, 1e6]:
    for kq in [0.5, 10.0, 1000.0, 1e6]:
        # Means whose f64 coordinates are exactly unit (only axis-aligned ones are), so that the
        # value does not depend on how a nearly unit vector is read.
        for mq in [[mp.mpf(0), mp.mpf(0), mp.mpf(1)], [mp.mpf(1), mp.mpf(0), mp.mpf(0)]]:
            kpm, kqm = mp.mpf(kp), mp.mpf(kq)
            # (eta_p - eta_q) . E_p[x] - ln Z_p + ln Z_q with mu_p = z.
            dot = mq[2]
            kl = vmf_a(kpm) * (kpm - kqm * dot) + vmf_log_c(kpm) - vmf_log_c(kqm)
            vmf_kl.append({"kappa_p": kp, "kappa_q": kq, "mean_q": [f(v) for v in mq], "kl": f(kl)})


def gvm_log_z(e1, e2):
    e1 = [mp.mpf(v) for v in e1]
    e2 = [mp.mpf(v) for v in e2]
    g = lambda t: e1[0] * mp.cos(t) + e1[1] * mp.sin(t) + e2[0] * mp.cos(2 * t) + e2[1] * mp.sin(2 * t)
    grid = [-PI + 2 * PI * i / 512 for i in range(513)]
    top = max(g(t) for t in grid)
    maxima = [t for i, t in enumerate(grid[1:-1], 1) if g(t) >= g(grid[i - 1]) and g(t) >= g(grid[i + 1])]
    kappa = abs(e1[0]) + abs(e1[1]) + 4 * (abs(e2[0]) + abs(e2[1]))
    width = 1 / mp.sqrt(1 + kappa)
    points = sorted({-PI, PI} | {m + j * width for m in maxima for j in (-40, -10, -3, -1, 0, 1, 3, 10, 40)
                                  if -PI < m + j * width < PI})
    integral = mp.quad(lambda t: mp.exp(g(t) - top), points)
    return top + mp.log(integral), g


gvm = []
for e1, e2, angles in [
    ((3.0, 0.0), (0.0, 0.0), [0.0, 1.0, 3.0]),
    ((800.0, 0.0), (0.0, 0.0), [0.0, 1e-3, 0.1]),
    ((2.0, -1.0), (-0.5, 1.5), [0.0, 1.0, -2.0]),
    ((40.0, 0.0), (-60.0, 0.0), [0.0, 1.0, 2.0]),
    ((1e5, 0.0), (2e4, 0.0), [0.0, 1e-3, 0.01]),
    ((1e6, 0.0), (-1e5, 0.0), [0.0, 1e-3, 3.0]),
]:
    log_z, g = gvm_log_z(e1, e2)
    for a in angles:
        gvm.append({"eta1": list(e1), "eta2": list(e2), "angle": a,
                    "log_normalizer": f(log_z), "log_pdf": f(g(mp.mpf(a)) - log_z)})


def bingham_log_k(z):
    z = [mp.mpf(v) for v in z]
    (za, zb), (zc, zd) = (z[0], z[2]), (z[1], z[3])
    spread = max(z) - min(z)

    def integrand(t):
        u = 1 - t
        return (mp.exp(t * (za + zb) / 2 - max(z)) * mp.besseli(0, t * (za - zb) / 2)
                * mp.exp(u * (zc + zd) / 2) * mp.besseli(0, u * (zc - zd) / 2))

    breaks = sorted({mp.mpf(0), mp.mpf(1)} | {c / spread for c in (1, 10, 100)} |
                    {1 - c / spread for c in (1, 10, 100)} if spread > 200 else {mp.mpf(0), mp.mpf(1)})
    breaks = [b for b in breaks if 0 <= b <= 1]
    return max(z) + mp.log(mp.quad(integrand, breaks))


bingham = []
POINTS4 = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.5, 0.5, 0.5, 0.5], [0.0, 0.0, 0.0, 1.0]]
for z in [[0.0, -0.5, -1.0, -2.0], [0.0, -20.0, -300.0, -1000.0], [0.0, -2000.0, -5000.0, -1e4],
          [0.0, -1e5, -1e5, -1e5], [0.0, -3e5, -6e5, -1e6], [0.0, 0.0, -1e6, -1e6],
          [1e6, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, -7.0]]:
    log_k = bingham_log_k(z)
    for q in POINTS4:
        value = sum(mp.mpf(zk) * mp.mpf(qk) ** 2 for zk, qk in zip(z, q)) - log_k
        bingham.append({"z": z, "q": q, "log_normalizer": f(log_k), "log_pdf": f(value)})


def heat_log_f(s, t):
    s, t = mp.mpf(s), mp.mpf(t)
    if s < 1:
        def image(m):
            a = t + 2 * PI * m
            return (-1) ** m * a * mp.exp(-a * a / (2 * s))
        total = mp.fsum(image(m) for m in range(-12, 13))
        half = mp.sin(t / 2) if t > 0 else None
        if t == 0:
            # limit t -> 0: sum_m (-1)^m (t + 2 pi m) e^{...} / sin(t/2) -> derivative form
            h = mp.mpf(10) ** -30
            return heat_log_f(s, h)
        return mp.log(mp.sqrt(2 * PI) * s ** mp.mpf(-1.5) * mp.exp(s / 8) * total / half)
    terms = []
    for l in range(0, 400):
        w = (2 * l + 1) * mp.exp(-l * (l + 1) * s / 2)
        ratio = (2 * l + 1) if t == 0 else mp.sin((l + mp.mpf(1) / 2) * t) / mp.sin(t / 2)
        terms.append(w * ratio)
        if w < mp.mpf(10) ** -60:
            break
    return mp.log(mp.fsum(terms))


for s in [0.5, 0.9]:
    for t in [0.3, 2.0]:
        series = mp.log(mp.fsum((2 * l + 1) * mp.exp(-l * (l + 1) * mp.mpf(s) / 2)
                                * mp.sin((l + mp.mpf(1) / 2) * t) / mp.sin(mp.mpf(t) / 2) for l in range(400)))
        assert abs(series - heat_log_f(s, t)) < mp.mpf(10) ** -40, (s, t)

heat = []
for s in [1e-300, 1e-100, 1e-12, 1e-4, 0.1, 0.99, 1.0, 3.0, 100.0, 1e300]:
    for t in [1e-160, 1e-8, 1e-3, 0.5, 2.0, float(mp.pi)]:
        if t < 1e-100 < s:
            continue
        heat.append({"s": s, "t": t, "log_pdf": f(heat_log_f(s, t))})

gaussian = []
for sigma2 in [1e-100, 1e-50, 1e-3, 1.0, 1e50, 1e100]:
    sd = mp.sqrt(mp.mpf(sigma2))
    for scaled in [[0.0, 0.0, 0.0], [1.0, -2.0, 0.5], [30.0, 0.0, 0.0]]:
        mean = [1.5, -2.0, 0.25]
        x = [float(mp.mpf(m) + sd * v) for m, v in zip(mean, scaled)]
        d2 = mp.fsum((mp.mpf(a) - mp.mpf(b)) ** 2 for a, b in zip(x, mean)) / mp.mpf(sigma2)
        value = -(3 * mp.log(2 * PI) + 3 * mp.log(mp.mpf(sigma2)) + d2) / 2
        gaussian.append({"variance": sigma2, "mean": mean, "x": x, "log_pdf": f(value)})

out = {
    "about": "mpmath at 50 digits, by tools/reference_densities.py; see tests/data/README.md",
    "von_mises": von_mises, "von_mises_entropy": vm_entropy, "von_mises_kl": vm_kl,
    "von_mises_fisher": vmf, "von_mises_fisher_entropy": vmf_entropy, "von_mises_fisher_kl": vmf_kl,
    "gen_von_mises2": gvm, "bingham": bingham, "heat_kernel_so3": heat, "gaussian": gaussian,
}
def as_strings(v):
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, list):
        return [as_strings(x) for x in v]
    if isinstance(v, dict):
        return {k: as_strings(x) for k, x in v.items()}
    return v


with open("tests/data/density_reference.json", "w") as fh:
    json.dump(as_strings(out), fh, indent=1)
print({k: len(v) for k, v in out.items() if isinstance(v, list)})
