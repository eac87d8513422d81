"""No command runs for more than two seconds without printing: a stage made slow on purpose (every image takes
0.4 s to read) still shows its progress in time."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import threading
import time

from conftest import ROOT

from mitnerf.data.formats import save_dataset

SLOW_READS = textwrap.dedent("""
    import sys, time
    import mitnerf.data.formats.common as common
    from mitnerf.cli import main
    read = common.read_image
    def slow(path):
        time.sleep(0.4)
        return read(path)
    for module in list(sys.modules.values()):              # every reader that imported it
        if getattr(module, "read_image", None) is read:
            module.read_image = slow
    print("start", flush=True)
    sys.exit(main(sys.argv[1:]))
""")


def longest_silence(argv: list[str]) -> tuple[float, int, str]:
    """Run ``mitnerf argv`` with slow image reads; the longest stretch (s) without a byte on stdout or stderr after
    the command starts, its exit status and what it printed."""
    p = subprocess.Popen([sys.executable, "-c", SLOW_READS, *map(str, argv)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, cwd=ROOT)
    stamps, text, started = [], [], threading.Event()

    def pump(stream):
        while chunk := stream.read1(4096) if hasattr(stream, "read1") else stream.read(1):
            stamps.append(time.perf_counter())
            text.append(chunk.decode(errors="replace"))
            if b"start" in chunk:
                started.set()
    threads = [threading.Thread(target=pump, args=(s,)) for s in (p.stdout, p.stderr)]
    for t in threads:
        t.start()
    p.wait(timeout=300)
    for t in threads:
        t.join()
    end = time.perf_counter()
    out = "".join(text)
    first = next(i for i, c in enumerate(text) if "start" in c)
    times = sorted(stamps[first:]) + [end]
    return max(b - a for a, b in zip(times, times[1:])), p.returncode, out


def test_reading_a_slow_dataset_shows_progress(bunny_small, tmp_path):
    data = save_dataset(bunny_small.sparse(), tmp_path / "ds")        # 12 train + 8 test views: 8 s of reading
    gap, status, out = longest_silence(["show", data, "--out", tmp_path / "fig"])
    assert status == 0, out
    assert gap < 2.0, f"{gap:.1f} s without a word:\n{out}"
