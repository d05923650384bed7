#!/usr/bin/env python3
"""The live lens lab's latency: from a settings change to the first image of the new settings.

    python3 benches/gpu/live_latency.py [--realcam target/release/realcam] [--device gpu]
                                        [--size 1024] [--changes 12]

Starts `realcam serve --port 0 --device D --width S --height S` on the built-in scene with a
sample target far off (so a change always lands while passes run), waits for the first full
pass, then makes `--changes` changes in turn (focus pulls, stops, a lens swap and back), each
after the last one's first image: for each it prints the server's own figure (`first_image_
seconds` in /api/stats: from the change being applied to the first image published, a coarse
preview pass at most 128 px across) and the client's (from sending the POST to reading that
image's state back over HTTP, polled every millisecond). Medians at the end. Standard library
only.
"""

import argparse
import json
import re
import statistics
import subprocess
import sys
import time
import urllib.request


def call(url, body=None):
    data = None if body is None else json.dumps(body).encode()
    request = urllib.request.Request(url, data=data, method="POST" if body is not None else "GET",
                                     headers={"content-type": "application/json"})
    with urllib.request.urlopen(request, timeout=30) as reply:
        return json.loads(reply.read())


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--realcam", default="target/release/realcam")
    parser.add_argument("--device", default="gpu")
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--changes", type=int, default=12)
    args = parser.parse_args()
    server = subprocess.Popen(
        [args.realcam, "serve", "--port", "0", "--device", args.device, "--width", str(args.size),
         "--height", str(args.size), "--spp", "1000000", "--out", "/tmp/live_latency.png"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        base = None
        for line in server.stdout:
            match = re.search(r"(http://[0-9.:]+)/", line)
            if match:
                base = match.group(1)
                break
        if base is None:
            sys.exit("realcam serve printed no address")
        while call(base + "/api/state").get("spp_done", 0) < 1:
            time.sleep(0.01)
        changes = [{"focus_distance": 2.0}, {"focus_distance": 6.0}, {"f_number": 4},
                   {"f_number": 8}, {"lens": "wide.22mm"}, {"lens": "dgauss.50mm"}]
        server_times, client_times = [], []
        for i in range(args.changes):
            before = call(base + "/api/stats")["settings_changes"]
            start = time.perf_counter()
            call(base + "/api/settings", changes[i % len(changes)])
            while True:
                stats = call(base + "/api/stats")
                if stats["settings_changes"] > before and stats["first_image_seconds"] is not None:
                    break
                time.sleep(0.001)
            client_times.append(time.perf_counter() - start)
            server_times.append(stats["first_image_seconds"])
            print(f"{json.dumps(changes[i % len(changes)]):28} server {server_times[-1] * 1e3:7.1f} ms"
                  f"   client {client_times[-1] * 1e3:7.1f} ms", flush=True)
        stats = call(base + "/api/stats")
        print(f"{args.size}² on {args.device} ({stats.get('device')}): median first image after a change: "
              f"server {statistics.median(server_times) * 1e3:.1f} ms, client "
              f"{statistics.median(client_times) * 1e3:.1f} ms; full passes "
              f"{stats['samples_per_second'] / 1e6:.1f} M samples/s")
    finally:
        server.terminate()
        server.wait(timeout=10)


if __name__ == "__main__":
    main()
