#!/usr/bin/env python3
"""Peers of liebayes' attitude filters on BROAD, measured in one invocation.

Runs VQF (the authors' C++ through the batch API of the PyPI package `vqf`, 9D and 6D, default
parameters, online) on every BROAD trial in a folder, times it, runs `liebayes attitude --broad` on
the same folder in the same invocation, and prints one table with BROAD's metric (total / heading /
inclination RMSE, degrees) and the throughput ratio. With `--offline`, the offline estimates
instead: VQF's acausal `offlineVQF` (the same package, default parameters) against
`liebayes attitude --broad DIR --offline` (the production filter's RTS smoother).

    pip install vqf==2.1.2 scipy
    python3 tools/attitude_peers.py --broad DIR [--offline] [--liebayes target/release/liebayes] [--out DIR]

Not part of the test suite (it needs the two Python packages and the data).
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import scipy.io
from vqf import VQF, offlineVQF


def errors(est, ref, movement):
    """BROAD's metric: RMSE (deg) of total, heading and inclination errors over movement samples."""
    ok = movement & np.all(np.isfinite(ref), axis=1)
    e = quat_multiply(est[ok], quat_conj(ref[ok]))
    w, z = np.abs(e[:, 0]), np.abs(e[:, 3])
    horizontal = np.hypot(e[:, 1], e[:, 2])
    total = 2 * np.arctan2(np.hypot(horizontal, z), w)
    heading = 2 * np.arctan2(z, w)
    inclination = 2 * np.arctan2(horizontal, np.hypot(w, z))
    rms = lambda x: math.degrees(math.sqrt(np.mean(x * x)))
    return rms(total), rms(heading), rms(inclination)


def quat_conj(q):
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_multiply(a, b):
    w1, x1, y1, z1 = a.T
    w2, x2, y2, z2 = b.T
    return np.stack([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ], axis=1)


def load(path):
    m = scipy.io.loadmat(path)
    c = lambda name: np.ascontiguousarray(m[name], dtype=float)
    return {
        "gyr": c("imu_gyr"), "acc": c("imu_acc"), "mag": c("imu_mag"),
        "ref": c("opt_quat"), "movement": m["movement"].ravel().astype(bool),
        "rate": float(np.asarray(m["sampling_rate"]).ravel()[0]),
    }


def run_vqf(trial, nine_d, offline):
    ts = 1.0 / trial["rate"]
    start = time.perf_counter()
    if offline:
        # The offline variant computes 6D and 9D in one pass; without a magnetometer, the 6D.
        mag = trial["mag"] if nine_d else None
        out = offlineVQF(trial["gyr"], trial["acc"], mag, ts)
    elif nine_d:
        out = VQF(ts).updateBatch(trial["gyr"], trial["acc"], trial["mag"])
    else:
        out = VQF(ts).updateBatch(trial["gyr"], trial["acc"])
    elapsed = time.perf_counter() - start
    return out["quat9D" if nine_d else "quat6D"], elapsed


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--broad", required=True, help="folder with BROAD's NN_name.mat files")
    parser.add_argument("--liebayes", default="target/release/liebayes", help="the liebayes binary")
    parser.add_argument("--out", help="folder for liebayes' output (default: a temporary folder)")
    parser.add_argument("--repeats", type=int, default=5, help="timed repetitions of each batch")
    parser.add_argument("--offline", action="store_true",
                        help="the offline (acausal) estimates: offlineVQF and liebayes --offline")
    args = parser.parse_args()

    trials = sorted(f for f in os.listdir(args.broad) if f.endswith(".mat"))
    if not trials:
        sys.exit(f"no .mat files in {args.broad}")
    vqf_name = "offline VQF" if args.offline else "VQF"
    rows, timing = [], {"9D": [0.0, 0], "6D": [0.0, 0]}
    for name in trials:
        trial = load(os.path.join(args.broad, name))
        row = {"trial": name[:-4]}
        for label, nine_d in (("9D", True), ("6D", False)):
            best = math.inf
            for _ in range(max(1, args.repeats)):
                quat, elapsed = run_vqf(trial, nine_d, args.offline)
                best = min(best, elapsed)
            timing[label][0] += best
            timing[label][1] += len(trial["gyr"])
            row[f"{vqf_name} {label}"] = errors(quat, trial["ref"], trial["movement"])
        rows.append(row)

    out = args.out or tempfile.mkdtemp(prefix="liebayes_attitude_")
    cmd = [args.liebayes, "attitude", "--broad", args.broad, "--out", out]
    if args.offline:
        cmd.append("--offline")
    print("running:", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True, stdout=sys.stderr)
    with open(os.path.join(out, "broad.summary.json")) as f:
        ours = json.load(f)

    by_trial = {t["trial"]: t for t in ours["trials"]}
    methods = [f"{vqf_name} 9D", f"{vqf_name} 6D"] + ours["methods"]
    print()
    print("| trial | " + " | ".join(methods) + " |")
    print("|---|" + "---|" * len(methods))
    sums = {m: np.zeros(3) for m in methods}
    for row in rows:
        mine = by_trial.get(row["trial"], {}).get("errors", {})
        cells = []
        for m in methods:
            e = row.get(m) or mine.get(m)
            if e is None:
                cells.append("-")
                continue
            sums[m] += np.asarray(e)
            cells.append("%.2f / %.2f / %.2f" % tuple(e))
        print(f"| {row['trial']} | " + " | ".join(cells) + " |")
    n = len(rows)
    print("| mean | " + " | ".join("%.2f / %.2f / %.2f" % tuple(sums[m] / n) for m in methods) + " |")

    print()
    print("throughput, samples per second on one core (VQF: best of %d batch runs per trial)" % args.repeats)
    for label in ("9D", "6D"):
        seconds, samples = timing[label]
        vqf_rate = samples / seconds
        print(f"  {vqf_name} {label} (C++): {vqf_rate / 1e6:.2f} M/s")
        for m, rate in ours["throughput"].items():
            if m.endswith(label):
                print(f"  {m}: {rate / 1e6:.2f} M/s, {rate / vqf_rate:.2f} x {vqf_name} {label}")
    for m, rate in ours["throughput"].items():
        if not (m.endswith("9D") or m.endswith("6D")):
            print(f"  {m}: {rate / 1e6:.3f} M/s")


if __name__ == "__main__":
    main()
