"""examples/sweep.py on a local dask cluster: one CSV, a row per case, physics that orders."""
import csv
import os
import subprocess
import sys

from conftest import REPO


def test_small_sweep_on_a_local_cluster(tmp_path):
    out = tmp_path / "sweep.csv"
    cmd = [sys.executable, str(REPO / "examples" / "sweep.py"), "--young-modulus-kpa", "3", "12",
           "--masks", "phantom", "/nonexistent.nii.gz", "--until-s", "0.3", "--workers", "2",
           "-o", str(out)]
    # A mask that does not exist is refused before any cluster starts.
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "/nonexistent.nii.gz: no such mask" in done.stderr
    assert not out.exists()

    empty = tmp_path / "empty.nii.gz"
    empty.write_bytes(b"")  # exists, but is no mask: its rows carry the error
    cmd[cmd.index("/nonexistent.nii.gz")] = str(empty)
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=240,
                          env=dict(os.environ))
    assert done.returncode == 1, done.stderr  # some cases failed, the rest were written
    rows = list(csv.DictReader(out.open()))
    assert len(rows) == 4
    ok = [r for r in rows if not r["error"]]
    bad = [r for r in rows if r["error"]]
    assert len(ok) == 2 and len(bad) == 2
    assert all(str(empty) in r["error"] for r in bad)
    by_e = {float(r["young_modulus_kpa"]): r for r in ok}
    # Four times softer: the same poke dents it clearly more in the same 0.3 s.
    assert float(by_e[3.0]["peak_displacement_mm"]) > 1.5 * float(by_e[12.0]["peak_displacement_mm"])
    assert all(abs(float(r["time_s"]) - 0.3) < 1e-6 for r in ok)
    assert "wrote" in done.stderr and "4 rows, 2 failed" in done.stderr
