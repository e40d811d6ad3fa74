"""The package's fuzzer (tools/python_fuzz.py) at test size: every public entry called with extreme
and malformed arguments, from a fixed seed, must give no crash, panic, undocumented NaN or
infinity, or refused step that changes a filter. The long run is the documented command."""

import pathlib
import subprocess
import sys

FUZZER = pathlib.Path(__file__).resolve().parents[2] / "tools" / "python_fuzz.py"


def test_the_fuzzer_finds_nothing_at_test_size():
    # No watchdog (--timeout 0): the verdict must not depend on the machine's speed.
    run = subprocess.run(
        [sys.executable, str(FUZZER), "--cases", "3000", "--seed", "3", "--timeout", "0"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]
    assert "3000 cases: 0 findings (0 crashes)" in run.stdout
