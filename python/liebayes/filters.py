"""Filters and studies: the exact azimuth filter, the angle-of-arrival filters, and the library's
studies of its built-in scenarios, whose simulated runs are exposed so that a filter written in
Python can be run on exactly the same data and scored by the same rules.

Every library error is raised as ``ValueError`` with the library's message.
"""

from ._liebayes import (
    AoaFilter,
    ExactAzimuthFilter,
    aoa_runs,
    aoa_study,
    azimuth_runs,
    azimuth_study,
    score_aoa,
    score_azimuth,
    square_track,
)

__all__ = [
    "AoaFilter",
    "ExactAzimuthFilter",
    "aoa_runs",
    "aoa_study",
    "azimuth_runs",
    "azimuth_study",
    "score_aoa",
    "score_azimuth",
    "square_track",
]
