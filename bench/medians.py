#!/usr/bin/env python3
"""Medians of timed runs, for bench/threads.sh and bench/bars.sh.

Reads lines "TAG SECONDS" from standard input. Arguments: the tags to
print, in order, then "--" and the ratios to print as "A/B" (with an
optional ":NOTE" after each, printed beside it). When tags t1 and pair
were timed, also prints the machine's ceiling, 2 x t1 / pair: two
one-thread runs at once share nothing, so that is the most two threads
could give over one here, then.
"""
import collections
import statistics
import sys

args = sys.argv[1:]
tags = args[: args.index("--")] if "--" in args else args
ratios = args[args.index("--") + 1 :] if "--" in args else []
runs = collections.defaultdict(list)
for line in sys.stdin:
    tag, seconds = line.split()
    runs[tag].append(float(seconds))
median = {tag: statistics.median(times) for tag, times in runs.items()}
for tag in tags:
    print(tag, "median %.3f s" % median[tag], "n", len(runs[tag]))
parts = []
for ratio in ratios:
    spec, _, note = ratio.partition(":")
    a, b = spec.split("/")
    parts.append("%s %.3f%s" % (spec, median[a] / median[b], " (%s)" % note if note else ""))
if parts:
    print("  ".join(parts))
if "t1" in median and "pair" in median:
    print(
        "ceiling 2 x t1 / pair %.3f (the most two threads could give over one here, now)"
        % (2 * median["t1"] / median["pair"])
    )
