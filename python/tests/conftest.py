"""Shared fixtures: the repository's data and the `liebayes` binary."""

import os
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
BROAD_TRIAL = ROOT / "data" / "broad" / "01_undisturbed_slow_rotation_A.mat"


@pytest.fixture(scope="session")
def broad_trial():
    """A BROAD trial kept in the repository (CC BY 4.0, see data/broad/README.md)."""
    assert BROAD_TRIAL.is_file(), f"missing test data {BROAD_TRIAL}"
    return BROAD_TRIAL


@pytest.fixture(scope="session")
def liebayes_bin():
    """The `liebayes` binary: $LIEBAYES_BIN, else target/release or target/debug of the repository
    (built by `cargo build` or the test command)."""
    given = os.environ.get("LIEBAYES_BIN")
    if given:
        assert pathlib.Path(given).is_file(), f"LIEBAYES_BIN={given} is not a file"
        return given
    for profile in ("release", "debug"):
        candidate = ROOT / "target" / profile / "liebayes"
        if candidate.is_file():
            return str(candidate)
    pytest.fail("no liebayes binary: run `cargo build --release` or set LIEBAYES_BIN")
