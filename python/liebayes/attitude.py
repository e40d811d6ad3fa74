"""IMU attitude: the production filter with a batch API like VQF's, and the BROAD reader.

    import liebayes.attitude as att
    log = att.read_broad("data/broad/01_undisturbed_slow_rotation_A.mat")
    f = att.AttitudeFilter(rate=log["rate"])
    out = f.update_batch(log["gyr"], log["acc"], log["mag"])
    out["quat"]          # (n, 4), scalar first, IMU frame w.r.t. East-North-Up
    out["heading_sigma"] # (n,), rad
"""

from ._liebayes import AttitudeFilter, read_broad

__all__ = ["AttitudeFilter", "read_broad"]
