#!/usr/bin/env python3
"""Renders one pathlight image over many machines with Dask's distributed scheduler.

The image's samples are split into shards (`pathlight render --shard I/N`), each shard is
a Dask task that runs `pathlight render` on a worker, and the shards are merged exactly
(`pathlight merge`) by a tree of merge tasks on the workers. Dask does the scheduling and the fault tolerance: a task whose worker
dies is run again on another one (up to `distributed.scheduler.allowed-failures` times),
and `--retries` re-runs a shard whose render failed.

    # two local worker processes of one thread each
    python3 farm/pathlight_farm.py scenes/cornell-box.gltf -o cornell.exr --spp 256 --shards 8 --workers 2
    # an existing cluster (dask-scheduler / dask-worker on the machines, a shared folder)
    python3 farm/pathlight_farm.py SCENE -o OUT.exr --spp 4096 --shards 100 \\
        --scheduler tcp://head:8786 --work-dir /shared/render -- --width 1920 --height 1080

Arguments after `--` go to every `pathlight render`. Every worker must see the scene, the
pathlight binary (`--pathlight`) and the work folder at the same paths. The same shard
convention serves other schedulers without this script: a Kubernetes Indexed Job runs
`pathlight render ... --shard $JOB_COMPLETION_INDEX/N`, a Slurm job array
`--shard $SLURM_ARRAY_TASK_ID/N`, and `pathlight merge` joins what they wrote.
"""

import argparse
import ctypes
import os
import signal
import subprocess
import sys
import time


def _die_with_parent():
    """In the child: ask Linux to kill the render if the worker that started it dies, so
    that a killed worker leaves no orphan render behind (prctl PR_SET_PDEATHSIG)."""
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)
    except OSError:
        pass


def render_shard(pathlight, scene, spp, shard, shards, out_dir, extra):
    """One task: renders shard `shard` of `shards` to OUT_DIR/shard-I-of-N.exr and returns
    its path and seconds. Raises with the render's own message if it fails."""
    out = os.path.join(out_dir, f"shard-{shard}-of-{shards}.exr")
    cmd = [pathlight, "render", scene, "--spp", str(spp), "--shard", f"{shard}/{shards}", "-o", out, *extra]
    start = time.monotonic()
    run = subprocess.run(cmd, capture_output=True, text=True, preexec_fn=_die_with_parent)
    if run.returncode != 0:
        raise RuntimeError(f"shard {shard}/{shards} failed: {' '.join(cmd)}\n{run.stderr}")
    return out, time.monotonic() - start


def merge_parts(pathlight, parts, out):
    """One merge task: `pathlight merge PARTS -o OUT`; returns OUT and its seconds."""
    start = time.monotonic()
    run = subprocess.run([pathlight, "merge", *parts, "-o", out], capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"merge of {', '.join(parts)} failed:\n{run.stderr}")
    return out, time.monotonic() - start


def render_farm(client, pathlight, scene, output, spp, shards, work_dir, extra, retries=2, fan_in=4):
    """Submits the shards to `client` and merges them into `output` as a tree of merge tasks
    of at most `fan_in` parts each (merging is associative, so the tree's shape does not
    change the image; one merge of every shard would read them all on one machine).
    Returns (seconds per shard, seconds per merge task)."""
    os.makedirs(work_dir, exist_ok=True)
    tag = f"{shards}-{abs(hash(os.path.abspath(output)))}"
    level = [
        client.submit(render_shard, pathlight, scene, spp, i, shards, work_dir, list(extra),
                      key=f"pathlight-shard-{i}-of-{tag}", retries=retries, pure=False)
        for i in range(shards)
    ]
    shard_futures, merges, depth = list(level), [], 0
    while True:
        groups = [level[i:i + fan_in] for i in range(0, len(level), fan_in)]
        last = len(groups) == 1
        next_level = []
        for g, group in enumerate(groups):
            out = output if last else os.path.join(work_dir, f"merge-{depth}-{g}-of-{shards}.exr")
            paths = [client.submit(lambda r: r[0], f, pure=False) for f in group]
            next_level.append(client.submit(lambda ps, o: merge_parts(pathlight, ps, o), paths, out,
                                            key=f"pathlight-merge-{depth}-{g}-of-{tag}", retries=retries, pure=False))
        merges.extend(next_level)
        if last:
            break
        level, depth = next_level, depth + 1
    shard_seconds = [seconds for _, seconds in client.gather(shard_futures)]
    merge_seconds = [seconds for _, seconds in client.gather(merges)]
    return shard_seconds, merge_seconds


def main(argv):
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    else:
        extra = []
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene")
    p.add_argument("-o", "--output", required=True, help="the merged image (.exr)")
    p.add_argument("--spp", type=int, required=True, help="samples per pixel of the whole image")
    p.add_argument("--shards", type=int, required=True, help="parts the samples are split into")
    p.add_argument("--workers", type=int, default=2, help="local worker processes (without --scheduler)")
    p.add_argument("--scheduler", help="address of a running Dask scheduler, e.g. tcp://head:8786")
    p.add_argument("--pathlight", default=os.path.abspath("target/release/pathlight"))
    p.add_argument("--work-dir", default="out/farm", help="where the shards are written (shared by the workers)")
    p.add_argument("--retries", type=int, default=2, help="re-runs of a shard whose render failed")
    p.add_argument("--fan-in", type=int, default=4, help="parts per merge task (merges form a tree)")
    args = p.parse_args(argv)
    if not 1 <= args.shards <= args.spp:
        p.error("--shards must be between 1 and --spp")

    from distributed import Client, LocalCluster

    if args.scheduler:
        client = Client(args.scheduler)
    else:
        # One thread per worker: each shard's render uses the worker's cores itself.
        client = Client(LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True))
    start = time.monotonic()
    shard_seconds, merge_seconds = render_farm(
        client, os.path.abspath(args.pathlight), os.path.abspath(args.scene), args.output, args.spp,
        args.shards, os.path.abspath(args.work_dir), extra, args.retries, max(2, args.fan_in),
    )
    print(f"{args.shards} shards on {len(client.scheduler_info()['workers'])} worker(s) in "
          f"{time.monotonic() - start:.2f} s (shards {min(shard_seconds):.2f}–{max(shard_seconds):.2f} s, "
          f"{len(merge_seconds)} merge task(s) {sum(merge_seconds):.2f} s in all): {args.output}")
    client.close()


if __name__ == "__main__":
    main(sys.argv[1:])
