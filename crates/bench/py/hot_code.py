#!/usr/bin/env python3
"""How much instruction-cache room a benchmark's hot path takes.

Reads a callgrind profile written with `--dump-instr=yes` and counts the instructions executed
at least THRESHOLD times (the hot path, when THRESHOLD is the number of iterations), the
distinct 64-byte code lines they sit on, and how those lines fall into the sets of a 32 KiB
8-way L1 instruction cache (64 sets): a set holding more than 8 hot lines misses on every
iteration. Then the functions with the most hot lines. With --order FILE it also writes the hot
functions' mangled names, hottest first, for the linker's --symbol-ordering-file (an experiment
on layout, not a build setting of the library).

    valgrind --tool=callgrind --dump-instr=yes --callgrind-out-file=cg.out \\
        target/release/facade_sdo --count 4000 --only virtual
    python3 crates/bench/py/hot_code.py cg.out 3500 [--binary target/release/facade_sdo --order hot.txt]
"""

import argparse
import bisect
import collections
import re
import subprocess

LINE = 64
SETS = 64
WAYS = 8

COST = re.compile(r"^(0x[0-9a-fA-F]+|[+-]\d+|\*)\s+\S+\s+(\d+)$")
NAMED = re.compile(r"^c?fn=\((\d+)\)(?: (.*))?$")


def read_profile(path):
    """Instruction address -> (own count, function name), from a `positions: instr line` dump."""
    names = {}
    counts = collections.Counter()
    function_of = {}
    addr = 0
    current = None
    call_cost_next = False
    with open(path, encoding="utf-8", errors="replace") as f:
        for raw in f:
            line = raw.rstrip("\n")
            named = NAMED.match(line)
            if named:
                if named.group(2):
                    names[named.group(1)] = named.group(2)
                if line.startswith("fn="):
                    current = names.get(named.group(1), named.group(1))
                continue
            if line.startswith("calls="):
                # The next cost line is the call's inclusive cost, not its instruction's own.
                call_cost_next = True
                continue
            cost = COST.match(line)
            if not cost:
                continue
            pos = cost.group(1)
            if pos.startswith("0x"):
                addr = int(pos, 16)
            elif pos != "*":
                addr += int(pos)
            if call_cost_next:
                call_cost_next = False
                continue
            counts[addr] += int(cost.group(2))
            function_of[addr] = current
    return counts, function_of


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("profile")
    ap.add_argument("threshold", type=int, help="executions that make an instruction hot")
    ap.add_argument("--functions", type=int, default=15, help="functions to list")
    ap.add_argument("--binary", help="the profiled binary (for --order)")
    ap.add_argument("--order", help="write the hot functions' symbols here")
    args = ap.parse_args()

    counts, function_of = read_profile(args.profile)
    hot = [a for a, c in counts.items() if c >= args.threshold]
    lines = {a // LINE for a in hot}
    per_set = collections.Counter(line % SETS for line in lines)
    print(
        f"hot instructions {len(hot)}; {LINE}-byte lines {len(lines)} ({len(lines) * LINE} B); "
        f"fullest set {max(per_set.values(), default=0)} lines; "
        f"sets over {WAYS}: {sum(1 for n in per_set.values() if n > WAYS)}"
    )

    by_function = collections.defaultdict(list)
    for a in hot:
        by_function[function_of[a]].append(a)
    ranked = sorted(by_function.items(), key=lambda kv: -len({a // LINE for a in kv[1]}))
    for name, addrs in ranked[: args.functions]:
        span = max(addrs) - min(addrs)
        print(f"{len({a // LINE for a in addrs}):4d} lines {len(addrs):5d} instr  span {span:6d} B  {name}")

    if args.order:
        if not args.binary:
            ap.error("--order needs --binary")
        out = subprocess.run(["nm", "-S", args.binary], capture_output=True, text=True, check=True)
        symbols = []
        for row in out.stdout.splitlines():
            parts = row.split()
            if len(parts) == 4 and parts[2] in "tTwW":
                symbols.append((int(parts[0], 16), int(parts[1], 16), parts[3]))
        symbols.sort()
        starts = [s[0] for s in symbols]
        heat = collections.Counter()
        for a in hot:
            i = bisect.bisect_right(starts, a) - 1
            if i >= 0 and symbols[i][0] <= a < symbols[i][0] + symbols[i][1]:
                heat[symbols[i][2]] += counts[a]
        with open(args.order, "w", encoding="utf-8") as f:
            for name, _ in heat.most_common():
                f.write(name + "\n")
        print(f"{len(heat)} hot symbols written to {args.order}")


if __name__ == "__main__":
    main()
