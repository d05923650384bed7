#!/usr/bin/env python3
"""Two or more builds of a divan bench binary side by side: each run in turn, ROUNDS times, and
per bench row the fastest time of each binary over the rounds, and the last binary's ÷ the
first's. For changes whose effect is smaller than a noisy machine's drift: interleaving puts
the drift on every binary alike.

    cargo bench --bench bvh --no-run        # at each commit; copy target/release/deps/bvh-*
    python3 benches/bvh_side_by_side.py BEFORE,AFTER 4 anchor closest_bounce_batch per_ray

Arguments: the binaries (comma-separated), the rounds, then the bench filters."""

import collections
import re
import subprocess
import sys

UNITS = {"ns": 1e-6, "µs": 1e-3, "us": 1e-3, "ms": 1.0, "s": 1e3}
TIME = re.compile(r"^([\d.]+) (ns|µs|us|ms|s)\s")
ROW = re.compile(r"^([│ ]*)[├╰]─ (.+?)(?:\s{2,}(.*))?$")


def rows(output: str):
    """(name, milliseconds) per timed row of a divan run; a row's time may follow a `note:` line."""
    group, pending = None, None
    for line in output.splitlines():
        row = ROW.match(line)
        if row:
            indent, label, rest = row.group(1), row.group(2).strip(), row.group(3) or ""
            if not indent:
                group = label
            name = f"{group}/{label}" if indent else label
            time = TIME.match(rest)
            if time:
                yield name, float(time.group(1)) * UNITS[time.group(2)]
                pending = None
            else:
                pending = name
            continue
        time = TIME.match(line)
        if time and pending:
            yield pending, float(time.group(1)) * UNITS[time.group(2)]
            pending = None


def main() -> None:
    binaries = sys.argv[1].split(",")
    rounds = int(sys.argv[2])
    filters = sys.argv[3:]
    best = collections.defaultdict(dict)
    for _ in range(rounds):
        for index, binary in enumerate(binaries):
            output = subprocess.run([binary, "--bench", *filters], capture_output=True,
                                    text=True, check=True).stdout
            for name, ms in rows(output):
                best[name][index] = min(best[name].get(index, float("inf")), ms)
    print(f"{'row':<72} " + " ".join(f"{i:>9}" for i in range(len(binaries))) + "   last÷first")
    for name, times in best.items():
        values = [times.get(i, float("nan")) for i in range(len(binaries))]
        print(f"{name:<72} " + " ".join(f"{v:9.3f}" for v in values) + f"   {values[-1] / values[0]:9.3f}")


if __name__ == "__main__":
    main()
