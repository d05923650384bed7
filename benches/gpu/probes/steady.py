"""Steady pass time against the first passes', from `realcam render --stats` files.

Reads FOLDER/SCENE.tTHREADS.sSPP.ROUND.json (renders of each scene and thread count at two
sample counts, several rounds), takes the median pass time (the five pass stages' seconds) at
each count, and prints the steady pass time, (time at the higher count − at the lower) ÷ their
difference, beside the mean pass time of the lower count's passes, then 1 → 16 threads.

    python3 benches/gpu/probes/steady.py FOLDER
"""
import glob, json, os, statistics, sys
runs = {}
for p in glob.glob(os.path.join(sys.argv[1], "*.json")):
    scene, t, s, k = os.path.basename(p)[:-5].split(".")
    d = json.load(open(p))
    runs.setdefault((scene, int(t[1:])), {}).setdefault(int(s[1:]), []).append(sum(d["stage_seconds"].get(x, 0) for x in ("generate_rays", "trace", "shade", "land_companions", "weight", "write_film")))
per = {}
for (scene, t), by in sorted(runs.items()):
    lo, hi = min(by), max(by)
    a, b = statistics.median(by[lo]), statistics.median(by[hi])
    step = (b - a) / (hi - lo)
    per[(scene, t)] = (step, a / lo)
    print(f"{scene} {t:2d} threads: passes {lo} spp {a:.3f} s, {hi} spp {b:.3f} s; steady pass {step*1e3:.1f} ms, first {lo} passes {a/lo*1e3:.1f} ms each; runs lo {by[lo]} hi {by[hi]}")
for scene in ("helmet", "spheres"):
    if (scene, 1) in per and (scene, 16) in per:
        print(f"{scene}: steady 1 -> 16 threads {per[(scene,1)][0]/per[(scene,16)][0]:.2f}x; first passes {per[(scene,1)][1]/per[(scene,16)][1]:.2f}x")
