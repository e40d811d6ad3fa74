"""IMU attitude: the production filter with a batch API like VQF's, and the BROAD reader.

    import liebayes.attitude as att
    log = att.read_broad("data/broad/01_undisturbed_slow_rotation_A.mat")
    f = att.AttitudeFilter(rate=log["rate"])
    out = f.update_batch(log["gyr"], log["acc"], log["mag"])
    out["quat"]          # (n, 4), scalar first, IMU frame w.r.t. East-North-Up
    out["heading_sigma"] # (n,), rad

    # The offline estimate of the whole recording (every sample given every sample), like
    # VQF's offlineVQF:
    smoothed = att.offline_attitude(log["gyr"], log["acc"], log["mag"], rate=log["rate"])
"""

from ._liebayes import AttitudeFilter, offline_attitude, offline_default_params, read_broad

__all__ = ["AttitudeFilter", "offline_attitude", "offline_default_params", "read_broad"]
