#!/usr/bin/env python3
"""CI test of the farm driver on a local Dask cluster of two worker processes: one worker is
killed while it renders a shard, and the merged image must still equal the single-machine
render of the same seed. Run from the repository root after `cargo build --release`:

    python3 farm/test_farm.py
"""

import os
import signal
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pathlight_farm  # noqa: E402

PATHLIGHT = os.path.abspath("target/release/pathlight")
SCENE = os.path.abspath("scenes/cornell-box.gltf")
SPP, SHARDS = 64, 4
# Big enough that a shard takes a second or two, so the kill lands while one runs.
RENDER = ["--backend", "cpu", "--width", "200", "--height", "200", "--seed", "3"]


def main():
    from distributed import Client, LocalCluster

    work = tempfile.mkdtemp(prefix="pathlight-farm-test-")
    whole = os.path.join(work, "whole.exr")
    subprocess.run([PATHLIGHT, "render", SCENE, "--spp", str(SPP), "-o", whole, *RENDER],
                   check=True, capture_output=True)

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True)
    client = Client(cluster)
    killed = {}

    def kill_a_worker_mid_shard():
        # Wait until a shard has been running a moment, then kill its worker's process
        # outright, checking just before that the shard has not written its image yet.
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            busy = {w: [k for k in keys if str(k).startswith("pathlight-shard-")]
                    for w, keys in client.processing().items()}
            busy = {w: keys for w, keys in busy.items() if keys}
            if busy:
                time.sleep(0.2)
                worker, keys = next(iter(busy.items()))
                pid = client.run(os.getpid, workers=[worker])[worker]
                shard = int(str(keys[0]).split("-")[2])
                out = os.path.join(work, "shards", f"shard-{shard}-of-{SHARDS}.exr")
                if os.path.exists(out):
                    continue
                os.kill(pid, signal.SIGKILL)
                killed.update(worker=worker, pid=pid, shard=shard)
                return
            time.sleep(0.05)

    killer = threading.Thread(target=kill_a_worker_mid_shard)
    killer.start()
    merged = os.path.join(work, "merged.exr")
    # A fan-in of 2: four shards merge in a tree of three tasks.
    shard_seconds, merge_seconds = pathlight_farm.render_farm(
        client, PATHLIGHT, SCENE, merged, SPP, SHARDS, os.path.join(work, "shards"), RENDER, fan_in=2)
    assert len(merge_seconds) == 3, merge_seconds
    killer.join()
    assert killed, "no shard was seen running, so no worker was killed"
    print(f"killed worker {killed['worker']} (pid {killed['pid']}) while it rendered shard {killed['shard']}; "
          f"shards took {min(shard_seconds):.2f}–{max(shard_seconds):.2f} s, {len(merge_seconds)} merges "
          f"{sum(merge_seconds):.2f} s")
    client.close()
    cluster.close()

    # The merged image is the single render up to the order of its sums: values up to the
    # lamp's 17 agree to 1e-5 relative (tests/merge.rs says why), so 2e-4 absolute.
    compare = subprocess.run([PATHLIGHT, "compare", merged, whole, "--max-abs", "2e-4"],
                             capture_output=True, text=True)
    print(compare.stdout)
    assert compare.returncode == 0, f"the merged image differs from the single render:\n{compare.stdout}{compare.stderr}"
    print("farm test passed")


if __name__ == "__main__":
    main()
