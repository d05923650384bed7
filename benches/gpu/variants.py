#!/usr/bin/env python3
"""Side-by-side renders of realcam variants on the peer scenes, on one machine in one run.

A variant is a binary with environment settings and extra render options, written
`NAME|BINARY|ENV=VALUE,...|OPTIONS` (the last two parts may be empty), e.g.
`flat|.bin/realcam|REALCAM_NESTED_PARALLEL=0|` or `w1|.bin/realcam||--device gpu --wavelengths 1`.
Each round renders every scene at every thread count with every variant in turn (interleaved,
so a drift of the machine's clock or temperature touches all alike), with compare.py's peer
settings (dgauss.50mm at an 8 mm stop, 35 mm film, from 4.5 m, white sky, depth 5). Per render
it keeps the --stats JSON and the process's resource use (user and system CPU-seconds, page
faults, context switches); then it prints, per scene and thread count, each variant's median
pass rate against the first variant's, and its medians of the resource use; with `--stages`,
each pass stage's median seconds too (which stage a change moved, where a frame's rate is too
noisy to tell).

    python3 benches/gpu/variants.py --work .peers --size 640 --spp 32 --threads 1,16 \\
        --repeat 3 --variant 'base|.bin/realcam||' --variant 'flat|.bin/realcam|REALCAM_NESTED_PARALLEL=0|' \\
        --results variants.json

Only the standard library; runs wherever realcam does (the GPU machines have no registry).
"""

import argparse
import json
import os
import resource
import shlex
import statistics
import subprocess
import sys
import tempfile
import time


def parse_variant(text):
    parts = text.split("|")
    if len(parts) != 4 or not parts[0] or not parts[1]:
        raise argparse.ArgumentTypeError(f"variant {text!r}: write NAME|BINARY|ENV=VALUE,...|OPTIONS")
    env = {}
    for setting in filter(None, parts[2].split(",")):
        key, sep, value = setting.partition("=")
        if not sep:
            raise argparse.ArgumentTypeError(f"variant {text!r}: {setting!r} is not ENV=VALUE")
        env[key] = value
    return {"name": parts[0], "binary": parts[1], "env": env, "options": shlex.split(parts[3])}


def render(variant, glb, size, spp, threads, timeout):
    with tempfile.TemporaryDirectory() as tmp:
        stats_path = os.path.join(tmp, "stats.json")
        command = [
            variant["binary"], "render", glb, "--lens", "dgauss.50mm", "--aperture", "8",
            "--film-diagonal", "35", "--look-from", "0,0,4.5", "--look-at", "0,0,0",
            "--env", "1,1,1", "--width", str(size), "--height", str(size), "--spp", str(spp),
            "--max-depth", "5", "--threads", str(threads), "--out", os.path.join(tmp, "out.png"),
            "--stats", stats_path, *variant["options"],
        ]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.monotonic()
        result = subprocess.run(command, env={**os.environ, **variant["env"]}, capture_output=True,
                                text=True, timeout=timeout)
        wall = time.monotonic() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if result.returncode != 0:
            raise RuntimeError(f"{variant['name']} failed ({result.returncode}): {result.stderr[-800:]}")
        stats = json.load(open(stats_path))
    usage = {field: getattr(after, field) - getattr(before, field)
             for field in ("ru_utime", "ru_stime", "ru_minflt", "ru_majflt", "ru_nvcsw", "ru_nivcsw")}
    return {"stats": stats, "usage": usage, "process_seconds": wall}


def main():
    # `@FILE` reads arguments from FILE, one a line (benches/gpu/probes keeps the runs made).
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0], fromfile_prefix_chars="@")
    parser.add_argument("--work", default=".peers", help="folder holding helmet.glb and spheres.glb")
    parser.add_argument("--scenes", default="helmet,spheres")
    parser.add_argument("--size", type=int, default=640)
    parser.add_argument("--spp", type=int, default=32)
    parser.add_argument("--threads", default=str(os.cpu_count()), help="comma-separated counts")
    parser.add_argument("--repeat", type=int, default=3, help="rounds (1 for single-thread renders)")
    parser.add_argument("--single-thread-rounds", type=int, default=1,
                        help="rounds for single-thread renders (at most --repeat)")
    parser.add_argument("--stages", action="store_true",
                        help="also print each stage's median seconds (--stats' stage_seconds)")
    parser.add_argument("--variant", type=parse_variant, action="append", required=True)
    parser.add_argument("--timeout", type=float, default=120)
    parser.add_argument("--budget", type=float, default=600, help="seconds; later rounds are skipped")
    parser.add_argument("--results", help="write every render's figures here (JSON)")
    args = parser.parse_args()
    scenes = args.scenes.split(",")
    threads = [int(t) for t in args.threads.split(",")]
    start = time.monotonic()
    runs = []
    for round_ in range(args.repeat):
        for scene in scenes:
            for count in threads:
                if count == 1 and round_ >= args.single_thread_rounds:
                    continue
                for variant in args.variant:
                    if time.monotonic() - start > args.budget:
                        print(f"budget of {args.budget:.0f} s spent: round {round_ + 1} stops here")
                        break
                    glb = os.path.join(args.work, f"{scene}.glb")
                    try:
                        run = render(variant, glb, args.size, args.spp, count, args.timeout)
                    except (RuntimeError, subprocess.TimeoutExpired) as error:
                        print(f"{scene} {count} threads {variant['name']}: {error}")
                        continue
                    run.update(scene=scene, threads=count, variant=variant["name"], round=round_)
                    runs.append(run)
                    print(f"{scene:<8} {count:>3} threads {variant['name']:<12} "
                          f"{run['stats']['samples_per_second'] / 1e6:8.2f} M samples/s", flush=True)
    if args.results:
        with open(args.results, "w") as out:
            json.dump({"size": args.size, "spp": args.spp, "cpus": os.cpu_count(), "runs": runs,
                       "variants": args.variant}, out, indent=1)
    print(f"\n{args.size}², {args.spp} spp, medians; ratio: pass rate ÷ the first variant's")
    print(f"{'scene':<8}{'threads':>8}  {'variant':<12}{'M/s':>8}{'ratio':>7}{'user s':>8}{'sys s':>7}"
          f"{'minflt':>9}{'invol cs':>9}{'load+bvh':>9}  runs")
    for scene, count, group in grouped(runs, scenes, threads, args.variant):
        first = None
        for variant, mine in group:
            rates = [r["stats"]["samples_per_second"] / 1e6 for r in mine]
            rate = statistics.median(rates)
            first = first or rate
            med = lambda key: statistics.median(r["usage"][key] for r in mine)
            setup = statistics.median(r["stats"]["stage_seconds"].get("load_scene", 0)
                                      + r["stats"]["stage_seconds"].get("build_bvh", 0) for r in mine)
            print(f"{scene:<8}{count:>8}  {variant['name']:<12}{rate:8.2f}{rate / first:7.3f}"
                  f"{med('ru_utime'):8.2f}{med('ru_stime'):7.2f}{med('ru_minflt'):9.0f}"
                  f"{med('ru_nivcsw'):9.0f}{setup:9.2f}  {', '.join(f'{r:.2f}' for r in rates)}")
    if args.stages:
        print_stages(runs, scenes, threads, args.variant)
    return 0


def grouped(runs, scenes, threads, variants):
    """Per scene and thread count, each variant that rendered there with its runs, in order."""
    for scene in scenes:
        for count in threads:
            group = [(variant, [r for r in runs if (r["scene"], r["threads"], r["variant"])
                                == (scene, count, variant["name"])]) for variant in variants]
            yield scene, count, [(variant, mine) for variant, mine in group if mine]


STAGES = ("generate_rays", "trace", "shade", "land_companions", "weight", "write_film")


def print_stages(runs, scenes, threads, variants):
    """Each pass stage's median wall seconds per variant, and its ratio to the first variant's."""
    print(f"\nstage seconds, medians (ratio to the first variant's)")
    print(f"{'scene':<8}{'threads':>8}  {'variant':<12}" + "".join(f"{stage:>22}" for stage in STAGES))
    for scene, count, group in grouped(runs, scenes, threads, variants):
        first = None
        for variant, mine in group:
            seconds = [statistics.median(r["stats"]["stage_seconds"].get(stage, 0) for r in mine)
                       for stage in STAGES]
            first = first or seconds
            cells = "".join(f"{s:14.3f} ({s / f if f else 0:5.3f})" for s, f in zip(seconds, first))
            print(f"{scene:<8}{count:>8}  {variant['name']:<12}{cells}")


if __name__ == "__main__":
    sys.exit(main())
