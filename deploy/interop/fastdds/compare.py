#!/usr/bin/env python3
"""Compare the Fast DDS reader's samples with a swarmloc run directory's estimates.csv.

usage: compare.py READER_CSV RUN_DIR [--mode lockstep|free_run] [--min-coverage 0.9]

estimates.csv has one row per (world step, agent): the newest estimate the orchestrator held when it
scored that step. In lockstep the orchestrator scores step s once every agent reported s + 1 steps run,
so the row (s, a) is exactly agent a's sample with steps_run = s + 1: the reader's samples are keyed by
(agent, steps_run - 1) and every one of them that the run directory has must carry the same values.
In free_run the orchestrator scores whatever arrived last, so there is no key; a row then counts as
received when the reader has a sample of that agent with the same values.

estimates.csv is written with 9 significant digits, so "same" means within half a unit in the 9th digit
(relative 5e-9); the reader prints 17 digits. Exit 0 on pass, 1 on fail, 2 on bad input.
"""
import argparse
import csv
import math
import sys
from collections import defaultdict

FIELDS = ("x_m", "y_m", "cov_xx", "cov_xy", "cov_yy")
REL_TOL = 5.0e-9 * (1 + 1e-6)  # half a unit in the 9th significant digit, plus float slack
ABS_FLOOR = 1e-15


def close(reader_value, csv_value):
    return abs(reader_value - csv_value) <= REL_TOL * abs(csv_value) + ABS_FLOOR


def load(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("reader_csv")
    parser.add_argument("run_dir")
    parser.add_argument("--mode", choices=("lockstep", "free_run"), default="lockstep")
    parser.add_argument("--min-coverage", type=float, default=0.9)
    args = parser.parse_args()

    try:
        got = [r for r in load(args.reader_csv) if int(r["steps_run"]) > 0]  # hellos carry the prior
        expected = load(args.run_dir + "/estimates.csv")
    except (OSError, KeyError, ValueError) as error:
        print(f"FAIL: cannot read inputs: {error}", file=sys.stderr)
        return 2
    if not expected:
        print("FAIL: estimates.csv is empty (did the run fail?)", file=sys.stderr)
        return 1

    values = lambda row: [float(row[k]) for k in FIELDS] + [int(row["valid"])]
    max_abs = 0.0
    max_abs_mean = 0.0  # x, y only: the covariance of a barely informed agent reaches 1e5 m^2
    max_rel = 0.0
    mismatches = []
    covered = 0
    if args.mode == "lockstep":
        by_key = defaultdict(list)
        for r in got:
            by_key[(int(r["agent"]), int(r["steps_run"]) - 1)].append(values(r))
        for row in expected:
            key = (int(row["agent"]), int(row["step"]))
            if key not in by_key:
                continue
            covered += 1
            want = values(row)
            for sample in by_key[key]:  # a repeated report (e.g. at STOP) must agree too
                max_abs_mean = max(max_abs_mean, abs(sample[0] - want[0]), abs(sample[1] - want[1]))
                for a, b in zip(sample[:-1], want[:-1]):
                    max_abs = max(max_abs, abs(a - b))
                    if b != 0.0:
                        max_rel = max(max_rel, abs(a - b) / abs(b))
                if sample[-1] != want[-1] or not all(close(a, b) for a, b in zip(sample[:-1], want[:-1])):
                    mismatches.append((key, sample, want))
    else:
        by_agent = defaultdict(list)
        for r in got:
            by_agent[int(r["agent"])].append(values(r))
        for row in expected:
            want = values(row)
            hit = None
            for sample in by_agent[int(row["agent"])]:
                if sample[-1] == want[-1] and all(close(a, b) for a, b in zip(sample[:-1], want[:-1])):
                    hit = sample
                    break
            if hit is None:
                continue
            covered += 1
            max_abs_mean = max(max_abs_mean, abs(hit[0] - want[0]), abs(hit[1] - want[1]))
            for a, b in zip(hit[:-1], want[:-1]):
                max_abs = max(max_abs, abs(a - b))
                if b != 0.0:
                    max_rel = max(max_rel, abs(a - b) / abs(b))

    coverage = covered / len(expected)
    agents = len({int(r["agent"]) for r in got})
    print(
        f"fastdds interop: mode {args.mode}, reader samples {len(got)} (from {agents} agents), "
        f"run-directory estimates {len(expected)}, received and compared {covered} ({100 * coverage:.1f} %), "
        f"mismatched {len(mismatches)}, max |diff| x/y {max_abs_mean:.3g} m, any field {max_abs:.3g}, "
        f"max rel diff {max_rel:.3g} (estimates.csv has 9 significant digits)"
    )
    for key, sample, want in mismatches[:10]:
        print(f"  mismatch (agent, step) {key}: reader {sample} vs estimates.csv {want}", file=sys.stderr)
    if mismatches:
        print(f"FAIL: {len(mismatches)} estimates differ between the Fast DDS reader and estimates.csv")
        return 1
    if coverage < args.min_coverage or not math.isfinite(coverage):
        print(f"FAIL: the Fast DDS reader got {100 * coverage:.1f} % of the estimates "
              f"(need >= {100 * args.min_coverage:.0f} %)")
        return 1
    print("PASS")
    return 0


if __name__ == "__main__":
    sys.exit(main())
