"""The study soak (issue 26, done-when): a 200-case design study on a local cluster whose
workers are killed at random (SIGKILL, seeded), its client killed once and restarted:
every case ends in the table exactly once, no case the table already held runs again,
and nothing else is lost.

NOT YET IN THE SUITE (the file name keeps pytest from collecting it; run it with
``python3 -m pytest -m slow -s tests/study/soak_study.py``, 1-4 min). Stop 25: passed 3
of 3 (48, 210, 48 s). Stop 26: 2 more passes, then a hang for good (the client blocked in
``distributed.wait(timeout=2)``, py-spy: the timeout never fired; the engine now polls
its futures' states instead), then 2 of 3 (60, 49 s); the third run's client ended
silently 7 s in, after a cluster start that failed once, with 4 cases in the table. A
diagnosis run found this harness reading a truncated table (see _rows); with that
mended, 3 of 3 (44-47 s). Stop 27: the logs kept from two failed runs of stop 26 show
their first client printing "RAN 200" with every case ok in the table: it had finished
before the harness saw a third of the cases (why the harness did not see them is not
known; the table reader was the one mended since). The harness now fails with the
client's log when a first client ends by itself. 8 of 8 passes (46-220 s, some beside
other work on the 2 cores). What it
found and what is fixed: a worker killed while the local cluster starts failed the study
(now started again, then named); finished cases whose futures the client still held
were computed again whenever their worker died (now released once recorded); a result
lost with its worker blocked the client's gather for ever (now a timeout, then the
cluster is looked at again); with that timeout at 10 s the restarted client livelocked
(the finished futures whose worker had died cost 10 s each, one after another, while the
kills lost the recomputed results again: the table stopped growing); at 1 s it passed.
"""

from __future__ import annotations

import contextlib
import os
import random
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

pytest.importorskip("distributed")
pq = pytest.importorskip("pyarrow.parquet")
psutil = pytest.importorskip("psutil")

from luff_study import write_luff_study

from pipeline.study.engine import KEPT, run_study

pytestmark = [pytest.mark.slow, pytest.mark.gmsh]

N_CASES = 200


def _client(study, out, links, log) -> subprocess.Popen:
    """The study in a process of its own (and its own session: its cluster dies with it);
    what it prints goes to ``log`` (a pipe nobody reads while it runs would block it)."""
    code = ("from pipeline.study.engine import run_study\n"
            "if __name__ == '__main__':\n"
            f"    r = run_study({str(study)!r}, out_root={str(out)!r}, workers=2, "
            f"cache_dir={str(links)!r})\n"
            "    print('RAN', r.ran, flush=True)\n")
    with open(log, "w") as fh:
        return subprocess.Popen([sys.executable, "-c", code], stdout=fh,
                                stderr=subprocess.STDOUT, start_new_session=True)


class _Killer(threading.Thread):
    """SIGKILLs one of the client's worker processes every 1-2.5 s (seeded); before
    that, while the first cluster starts, one worker as it comes up (the study starts
    its cluster again)."""

    def __init__(self, seed: int):
        super().__init__(daemon=True)
        self.rng, self.client, self.kills = random.Random(seed), None, 0
        self.stop = threading.Event()

    def run(self):
        first = True
        while not self.stop.wait(0.05 if first else self.rng.uniform(1.0, 2.5)):
            try:
                workers = [p for p in psutil.Process(self.client.pid).children(recursive=True)
                           if "spawn_main" in " ".join(p.cmdline())]
            except (psutil.Error, AttributeError):
                continue
            if first and workers:
                first = False  # a worker as the cluster starts
            elif workers:
                workers = [p for p in workers if time.time() - p.create_time() > 3.0]
            if workers:
                victim = self.rng.choice(sorted(workers, key=lambda p: p.pid))
                with contextlib.suppress(psutil.Error):
                    victim.send_signal(signal.SIGKILL)
                    self.kills += 1


def _rows(table):
    """The table's rows, read through one open file: the study replaces the file as it
    goes (atomically), and pq.read_table(path) opens it twice (its metadata, then its
    pages), so a replacement in between read a truncated table ("Page was smaller")."""
    try:
        with open(table, "rb") as fh:
            return pq.read_table(fh).to_pylist()
    except FileNotFoundError:
        return []


def test_random_worker_kills_and_a_client_kill_lose_nothing(tmp_path):
    angles = [round(float(a), 6) for a in np.linspace(-0.7, -1.2, N_CASES)]
    study = write_luff_study(tmp_path / "luff.yaml",
                             f"grid: {{drivers.LUFF.theta.value: {angles}}}")
    out, links = tmp_path / "out", tmp_path / "links"
    table = out / "luff" / "cases.parquet"
    killer = _Killer(seed=26)
    killer.client = _client(study, out, links, tmp_path / "client1.log")
    killer.start()
    try:
        t0 = time.time()  # the client is killed once a third of the cases are in
        while time.time() - t0 < 600 and killer.client.poll() is None and \
                len(_rows(table)) < N_CASES // 3:
            time.sleep(0.2)
    finally:
        ended = killer.client.poll()  # before the kill: the client must still be running
        os.killpg(killer.client.pid, signal.SIGKILL)  # the client and its cluster
        killer.client.wait()
    print(f"SOAK phase 1 {time.time() - t0:.1f} s", flush=True)
    assert ended is None, ("the first client ended (exit code "
                           f"{ended}) before a third of the cases were in the table: "
                           + (tmp_path / "client1.log").read_text()[-2000:])
    before = _rows(table)
    held = {r["input_hash"] for r in before if r["status"] in KEPT}
    assert N_CASES // 4 <= len(held) < N_CASES, len(held)

    # restarted, workers still being killed
    killer.client = _client(study, out, links, tmp_path / "client2.log")
    try:
        killer.client.wait(timeout=900)
    finally:
        killer.stop.set()
        if killer.client.poll() is None:
            os.killpg(killer.client.pid, signal.SIGKILL)
    print(f"SOAK phase 2 {time.time() - t0:.1f} s, {killer.kills} kills", flush=True)
    text = (tmp_path / "client2.log").read_text()
    assert killer.client.returncode == 0, text[-2000:]
    ran = int(text.split("RAN")[-1])
    assert ran == N_CASES - len(held)  # nothing the table held ran again
    assert killer.kills >= 10

    rows = _rows(table)
    hashes = [r["input_hash"] for r in rows]
    assert len(rows) == N_CASES and len(set(hashes)) == N_CASES
    assert all(r["status"] == b["status"] and r["out:peak_heave"] == b["out:peak_heave"]
               for r in rows for b in before if r["input_hash"] == b["input_hash"]
               and b["status"] in KEPT)
    left = [r for r in rows if r["status"] not in KEPT]  # lost to the kills, with a reason
    assert all(r["message"] for r in left)
    final = run_study(study, out_root=out, workers=2, cache_dir=links)
    assert final.ran == len(left)
    assert [r["status"] for r in final.rows] == ["ok"] * N_CASES
    assert len({r["input_hash"] for r in final.rows}) == N_CASES
    for r in final.rows:  # every case's file is on disk and readable
        with np.load(final.folder / "cases" / f"{r['input_hash'][:16]}.npz") as z:
            assert z.files == []  # a design study compares no series
