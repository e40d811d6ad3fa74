"""Speed of liebayes.densities against its Python peers, in one process (not a test).

* von Mises log density over 1e6 angles against scipy.stats.vonmises.logpdf;
* von Mises-Fisher log density over 1e6 unit vectors against scipy.stats.vonmises_fisher.logpdf;
* Bingham normaliser with its gradient against pyRecEst's (``pip install pyrecest``), when it is
  installed; its lru_cache is bypassed so that every call computes.

Build the extension in release mode first:

    cd python && maturin develop --release
    python ../tools/python_density_peers.py

Each figure is the best of several repetitions (wall clock of this machine; run it on an idle one).
"""

import math
import time

import numpy as np
from scipy import stats

from liebayes.densities import Bingham, VonMises, VonMisesFisher, bingham_log_normaliser

N = 1_000_000


def best(f, repeat=5):
    """The best wall-clock time of `repeat` calls of f, and its last result."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        result = f()
        times.append(time.perf_counter() - start)
    return min(times), result


def row(what, ours, peer, peer_name, n, agreement):
    ratio = peer / ours if ours > 0 else math.inf
    print(
        f"| {what} | {ours / n * 1e9:.1f} ns | {peer / n * 1e9:.1f} ns ({peer_name}) | {ratio:.1f}x | {agreement} |"
    )


def main():
    rng = np.random.default_rng(2026)
    print(f"numpy {np.__version__}, scipy {__import__('scipy').__version__}")
    print()
    print("| operation | liebayes per item | peer per item | speed-up | max difference |")
    print("|---|---|---|---|---|")

    # von Mises, 1e6 angles.
    mu, kappa = 0.7, 12.0
    x = rng.uniform(-np.pi, np.pi, N)
    p = VonMises(mu, kappa)
    ours_t, ours = best(lambda: p.log_pdf(x))
    peer_t, peer = best(lambda: stats.vonmises.logpdf(x, kappa, loc=mu))
    row("von Mises log_pdf, 1e6 angles", ours_t, peer_t, "scipy.stats.vonmises", N, f"{np.max(np.abs(ours - peer)):.1e}")

    # von Mises-Fisher, 1e6 unit vectors.
    m = np.array([0.0, 0.6, 0.8])
    v = rng.standard_normal((N, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    q = VonMisesFisher(m, 25.0)
    frozen = stats.vonmises_fisher(m, 25.0)
    ours_t, ours = best(lambda: q.log_pdf(v))
    peer_t, peer = best(lambda: frozen.logpdf(v))
    row(
        "von Mises-Fisher log_pdf, 1e6 vectors",
        ours_t,
        peer_t,
        "scipy.stats.vonmises_fisher",
        N,
        f"{np.max(np.abs(ours - peer)):.1e}",
    )

    # Sampling, for the record (no peer row: different algorithms and streams).
    gen = np.random.default_rng(1)
    t_vm, _ = best(lambda: p.sample(N, gen), repeat=3)
    t_sp, _ = best(lambda: stats.vonmises.rvs(kappa, loc=mu, size=N, random_state=gen), repeat=3)
    row("von Mises sample, 1e6 draws", t_vm, t_sp, "scipy.stats.vonmises.rvs", N, "-")

    # Bingham normaliser and gradient.
    try:
        from pyrecest.distributions.hypersphere_subset import bingham_distribution as pyrecest_bingham

        pyrecest_f = pyrecest_bingham._calculate_F_and_dF_cached.__wrapped__
    except ImportError as error:  # pragma: no cover - depends on the environment
        pyrecest_f = None
        print(f"\npyRecEst is not installed ({error}); Bingham rows without a peer.")

    for spread in (2.0, 100.0, 1e4):
        z = np.array([0.0, -0.3, -0.6, -1.0]) * spread
        calls = 2000
        ours_t, (log_k, grad) = best(lambda: [bingham_log_normaliser(z) for _ in range(calls)][-1])
        build_t, _ = best(lambda: [Bingham(np.eye(4), z) for _ in range(calls)])
        if pyrecest_f is not None:
            # pyRecEst: Z ascending with the last 0, surface measure of S^3 (a factor 2 pi^2).
            z_asc = tuple(float(a) for a in np.sort(z))
            peer_calls = 20
            peer_t, (f, df) = best(lambda: [pyrecest_f(z_asc) for _ in range(peer_calls)][-1], repeat=3)
            peer_log_k = math.log(f) - math.log(2 * math.pi**2) if f > 0 else float("nan")
            peer_grad = np.array(df)[::-1] / f if f > 0 else np.full(4, np.nan)
            diff = f"ln K {abs(peer_log_k - log_k):.1e}, grad {np.max(np.abs(peer_grad - grad)):.1e}"
            row(
                f"Bingham ln K + gradient, spread {spread:g}",
                ours_t,
                peer_t * calls / peer_calls,
                "pyRecEst",
                calls,
                diff,
            )
        else:
            print(f"| Bingham ln K + gradient, spread {spread:g} | {ours_t / calls * 1e9:.1f} ns | - | - | - |")
        print(f"| Bingham(V, z) construction, spread {spread:g} | {build_t / calls * 1e9:.1f} ns | - | - | - |")


if __name__ == "__main__":
    main()
