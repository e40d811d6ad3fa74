#!/usr/bin/env python3
"""The Python attitude API beside VQF's, in one invocation: samples per second of
`liebayes.attitude.AttitudeFilter.update_batch` and `vqf.VQF.updateBatch` (the authors' C++), and
of the offline estimates `liebayes.attitude.offline_attitude` and `vqf.offlineVQF`, on the same
BROAD trial, 9D and 6D, and BROAD's error of each (total / heading / inclination RMSE, deg).

    pip install ./python vqf==2.1.2
    python3 tools/python_attitude_peers.py [TRIAL.mat ...] [--repeats 5]

Not part of the test suite (it needs the `vqf` package); the figures are in docs/benchmarks.md.
"""
import argparse
import pathlib
import time

import numpy as np
from vqf import VQF, offlineVQF

import liebayes.attitude as att

ROOT = pathlib.Path(__file__).resolve().parents[1]


def errors(est, ref, movement):
    """BROAD's metric (deg): RMSE of the total, heading and inclination errors over the movement
    samples with a reference."""
    ok = movement & ~np.isnan(ref[:, 0])
    e = quat_multiply(est[ok], ref[ok] * [1, -1, -1, -1])
    w, z = np.abs(e[:, 0]), np.abs(e[:, 3])
    horizontal = np.hypot(e[:, 1], e[:, 2])
    total = 2 * np.arctan2(np.hypot(horizontal, z), w)
    heading = 2 * np.arctan2(z, w)
    inclination = 2 * np.arctan2(horizontal, np.hypot(w, z))
    return [np.degrees(np.sqrt(np.mean(x * x))) for x in (total, heading, inclination)]


def quat_multiply(a, b):
    w1, x1, y1, z1 = a.T
    w2, x2, y2, z2 = b.T
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=1)


def best_time(run, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        out = run()
        times.append(time.perf_counter() - start)
    return min(times), float(np.median(times)), out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trials", nargs="*", type=pathlib.Path,
                        default=sorted((ROOT / "data" / "broad").glob("*.mat")))
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    print(f"{'trial':40} {'filter':22} {'min ms':>8} {'median ms':>10} {'Msamples/s':>11} "
          f"{'total/heading/incl (deg)':>26}")
    for path in args.trials:
        log = att.read_broad(path)
        n, dt = log["gyr"].shape[0], 1.0 / log["rate"]
        gyr, acc, mag = (np.ascontiguousarray(log[k]) for k in ("gyr", "acc", "mag"))
        # VQF's accelerometer in m/s^2 and magnetometer in any unit, as ours; it reports
        # the IMU frame w.r.t. an ENU-like frame aligned to the first heading, as ours does (9D: ENU).
        runs = {
            "liebayes 9D": lambda: att.AttitudeFilter(dt).update_batch(gyr, acc, mag)["quat"],
            "vqf 9D (updateBatch)": lambda: VQF(dt).updateBatch(gyr, acc, mag)["quat9D"],
            "liebayes 6D": lambda: att.AttitudeFilter(dt).update_batch(gyr, acc)["quat"],
            "vqf 6D (updateBatch)": lambda: VQF(dt).updateBatch(gyr, acc)["quat6D"],
            "liebayes offline 9D": lambda: att.offline_attitude(gyr, acc, mag, dt=dt)["quat"],
            "offlineVQF 9D": lambda: offlineVQF(gyr, acc, mag, dt)["quat9D"],
            "liebayes offline 6D": lambda: att.offline_attitude(gyr, acc, dt=dt)["quat"],
            "offlineVQF 6D": lambda: offlineVQF(gyr, acc, None, dt)["quat6D"],
        }
        for label, run in runs.items():
            fastest, median, quat = best_time(run, args.repeats)
            e = errors(quat, log["quat"], log["movement"])
            print(f"{path.stem:40} {label:22} {fastest * 1e3:8.1f} {median * 1e3:10.1f} "
                  f"{n / fastest / 1e6:11.3f} {e[0]:8.2f} / {e[1]:.2f} / {e[2]:.2f}")


if __name__ == "__main__":
    main()
