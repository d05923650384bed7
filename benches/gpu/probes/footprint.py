#!/usr/bin/env python3
"""Does a pass's memory footprint set how far the CPU path scales?

The same camera samples at two frame sizes: 640² at 16 spp and 320² at 64 spp (6.55 M samples
each). A pass holds one sample of every pixel, so the tiles' batches of a 640² pass are four
times those of a 320² pass (about 0.7 KB a sample: some 290 MB at 640², beside a 300 MB L3 on
the lent machines). Each size renders with one thread, with $THREADS threads, as $THREADS
one-thread processes at once (the machine's ceiling), and as 4 processes of $THREADS/4 threads;
rounds alternate the sizes. Prints each rate, the scaling, and every stage's busy seconds (the
time inside the tiles' work, summed) beside the one-thread render's.

    python3 benches/gpu/probes/footprint.py --realcam .bin/realcam --work .peers --rounds 2
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

STAGES = ("generate_rays", "trace", "shade", "land_companions", "weight", "write_film")
SIZES = ((640, 16), (320, 64))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--realcam", default=".bin/realcam")
    parser.add_argument("--work", default=".peers")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--threads", type=int, default=os.cpu_count())
    parser.add_argument("--scenes", default="helmet,spheres")
    parser.add_argument("--out", default="/tmp/footprint")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    n = args.threads

    def command(scene, size, spp, threads, tag):
        stats = os.path.join(args.out, f"{tag}.json")
        return stats, [
            args.realcam, "render", os.path.join(args.work, f"{scene}.glb"), "--lens", "dgauss.50mm",
            "--aperture", "8", "--film-diagonal", "35", "--look-from", "0,0,4.5", "--look-at", "0,0,0",
            "--env", "1,1,1", "--width", str(size), "--height", str(size), "--spp", str(spp),
            "--max-depth", "5", "--threads", str(threads), "--out", os.path.join(args.out, f"{tag}.png"),
            "--stats", stats,
        ]

    def at_once(jobs):
        procs = [subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) for _, cmd in jobs]
        for p in procs:
            p.wait()
        out = []
        for stats, _ in jobs:
            try:
                out.append(json.load(open(stats)))
            except (OSError, ValueError):
                out.append(None)
        return out

    results = {}  # (scene, size, kind) -> list of per-round lists of stats
    start = time.time()
    for round_ in range(args.rounds):
        for scene in args.scenes.split(","):
            for size, spp in SIZES:
                base = f"{scene}.{size}.r{round_}"
                # Kind: (processes, threads each).
                kinds = {
                    "t1": (1, 1),
                    f"t{n}": (1, n),
                    f"copies{n}": (n, 1),
                    f"procs4x{n // 4}": (4, n // 4),
                }
                for kind, (procs, threads) in kinds.items():
                    jobs = [command(scene, size, spp, threads, f"{base}.{kind}.{k}") for k in range(procs)]
                    results.setdefault((scene, size, kind), []).append(at_once(jobs))
                print(f"[{time.time() - start:5.0f} s] {base} done", flush=True)

    for (scene, size, kind), rounds in results.items():
        rates = []
        for stats in rounds:
            if all(stats):
                rates.append(sum(s["samples_per_second"] for s in stats) / 1e6)
        results[(scene, size, kind)] = (rounds, rates)
    for scene in args.scenes.split(","):
        for size, spp in SIZES:
            one = results.get((scene, size, "t1"))
            if not one or not one[1]:
                continue
            one_rate = statistics.median(one[1])
            line = [f"{scene:<8} {size}² {spp:>2} spp: 1 thread {one_rate:6.2f} M/s (runs {', '.join(f'{r:.2f}' for r in one[1])})"]
            for kind in (f"t{n}", f"copies{n}", f"procs4x{n // 4}"):
                rounds, rates = results.get((scene, size, kind), ([], []))
                if rates:
                    r = statistics.median(rates)
                    line.append(f"{kind} {r:6.2f} = {r / one_rate:5.2f}× (runs {', '.join(f'{x:.2f}' for x in rates)})")
            print("; ".join(line))
            # Busy seconds per stage: one thread against the threads' (summed over threads).
            threads_rounds = results.get((scene, size, f"t{n}"), ([], []))[0]
            copies_rounds = results.get((scene, size, f"copies{n}"), ([], []))[0]
            for stage in STAGES:
                b1 = [s[0]["stage_busy_seconds"].get(stage, 0) for s in one[0] if s[0]]
                bn = [s[0]["stage_busy_seconds"].get(stage, 0) for s in threads_rounds if s and s[0]]
                bc = [statistics.median(x["stage_busy_seconds"].get(stage, 0) for x in s) for s in copies_rounds if s and all(s)]
                if b1 and statistics.median(b1) > 0.01:
                    m1 = statistics.median(b1)
                    text = f"    {stage:<16} busy: 1 thread {m1:6.3f} s"
                    if bn:
                        text += f"; {n} threads {statistics.median(bn):6.3f} s ({statistics.median(bn) / m1:.2f}×)"
                    if bc:
                        text += f"; a copy of {n} {statistics.median(bc):6.3f} s ({statistics.median(bc) / m1:.2f}×)"
                    print(text)
    print(f"done in {time.time() - start:.0f} s")


if __name__ == "__main__":
    sys.exit(main())
