"""Big freed arrays go back to the operating system (mcnkit.app.heap), so a long run's peak memory is what it holds."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

SCENARIO = textwrap.dedent("""
    import sys, numpy as np
    from mcnkit.app.heap import return_big_frees_to_os
    def rss_mb():
        return int(open("/proc/self/statm").read().split()[1]) * 4096 / 2**20
    if sys.argv[1] == "fixed":
        assert return_big_frees_to_os()
    a = np.ones(20 * 2**20 // 8); del a          # a mapped block freed: glibc's own threshold rises to 20 MiB
    base = rss_mb()
    big, kept = [], []
    for _ in range(10):
        big.append(np.ones(10 * 2**20 // 8))     # 10 MiB arrays ...
        kept.append(np.ones(100 * 2**10 // 8))   # ... with long-lived 100 KiB arrays between them
    del big
    print(rss_mb() - base)
""")


def _retained_mb(mode: str) -> float:
    out = subprocess.run([sys.executable, "-c", SCENARIO, mode], capture_output=True, text=True, check=True)
    return float(out.stdout.strip())


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_freed_big_arrays_leave_the_process_once_the_threshold_is_fixed() -> None:
    # glibc's default keeps the freed 100 MiB resident (stuck between the small arrays on the heap) ...
    assert _retained_mb("default") > 50
    # ... while with the threshold fixed at 8 MiB every 10 MiB array was its own mapping, unmapped when freed
    assert _retained_mb("fixed") < 10


def test_the_command_fixes_the_threshold_before_running(monkeypatch: pytest.MonkeyPatch) -> None:
    import mcnkit.app.heap
    from mcnkit.app.main import main

    calls: list[int] = []
    monkeypatch.setattr(mcnkit.app.heap, "return_big_frees_to_os", lambda: bool(calls.append(1)) or True)
    assert main(["info", "no-such.log"]) == 2  # any command, even one that fails at once
    assert calls == [1]
