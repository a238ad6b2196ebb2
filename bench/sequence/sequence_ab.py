#!/usr/bin/python3
"""Two ways of reconstructing a synthetic take's sequence, side by side: speed per stage
and what the sequence looks like (flicker, accuracy against the truth).

Usage: sequence_ab.py DOME TAKE OUT [--pairs N] [--a "FLAGS"] [--b "FLAGS"]

Runs `DOME run TAKE --out OUT/<side><k> --workers 2 FLAGS` for sides a and b, alternating
(a, b, a, b, ...: the machine's load falls on both alike), N pairs (default 2). Per run:
the whole process's wall seconds and, from OUT/.../report.json, the stereo and fusion job
seconds of the instants after the first (the ones a time-aware search can save on). The
last run of each side is then scored: flicker over the still parts and the moving parts'
accuracy (flicker.py, beside this script), the person box's accuracy median / p90 and
completeness at 10 / 20 mm (batter_eval, beside DOME), medians (completeness: means) over
the instants. Defaults: a = "--no-masks", b = "--no-masks --temporal" (time-aware
stereo against the plain search, time-aware fusion derived in both).

Prints one JSON line per run, one per side's scores, and a table with b / a ratios.
"""
import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import time


def call(cmd):
    """Runs cmd; on failure stops naming it, with the end of what it printed."""
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        tail = (r.stdout + r.stderr).strip().splitlines()[-20:]
        sys.exit(f"sequence_ab: {shlex.join(cmd)} exited {r.returncode}:\n" + "\n".join(tail))
    return r.stdout


def run(dome, take, out, flags):
    t0 = time.monotonic()
    call([dome, "run", take, "--out", out, "--workers", "2"] + flags)
    wall = time.monotonic() - t0
    report = json.load(open(os.path.join(out, "report.json")))
    later = report["per_instant"][1:]
    return {"out": out, "wall_s": round(wall, 2),
            "stereo_job_s_later": round(sum(p["job_seconds"]["stereo"] for p in later), 2),
            "fusion_job_s_later": round(sum(p["job_seconds"]["fusion"] for p in later), 2)}


def score(dome, take, out):
    here = os.path.dirname(os.path.abspath(__file__))
    flicker = json.loads(
        call(["/usr/bin/python3", os.path.join(here, "flicker.py"), take, out])
        .strip().splitlines()[-1])
    batter = os.path.join(os.path.dirname(dome), "batter_eval")
    lines = call([batter, take, out]).splitlines()
    box = [json.loads(l)["vs_truth_person_box"] for l in lines if l.startswith("{")]
    return {"out": out, "flicker_mm": flicker["flicker_rms_mm_median"],
            "moving_acc_mm": flicker["moving_accuracy_mm_median"],
            "box_acc_median_mm": round(statistics.median(b["acc_median_mm"] for b in box), 2),
            "box_acc_p90_mm": round(statistics.median(b["acc_p90_mm"] for b in box), 2),
            "completeness10": round(statistics.mean(b["completeness@10mm"] for b in box), 3),
            "completeness20": round(statistics.mean(b["completeness@20mm"] for b in box), 3)}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("dome")
    p.add_argument("take")
    p.add_argument("out")
    p.add_argument("--pairs", type=int, default=2)
    p.add_argument("--a", default="--no-masks")
    p.add_argument("--b", default="--no-masks --temporal")
    args = p.parse_args()
    dome = os.path.abspath(args.dome)
    os.makedirs(args.out, exist_ok=True)
    runs = {"a": [], "b": []}
    for k in range(args.pairs):
        for side in ("a", "b"):
            out = os.path.join(args.out, f"{side}{k}")
            subprocess.run(["rm", "-rf", out], check=True)
            r = run(dome, args.take, out, shlex.split(getattr(args, side)))
            r["side"] = side
            print(json.dumps(r), flush=True)
            runs[side].append(r)
    scores = {}
    for side in ("a", "b"):
        scores[side] = score(dome, args.take, runs[side][-1]["out"])
        scores[side]["side"] = side
        print(json.dumps(scores[side]), flush=True)
    med = lambda side, key: round(statistics.median(r[key] for r in runs[side]), 2)
    print(f"\n{'':28} {'a: ' + args.a:>24} {'b: ' + args.b:>30} {'b / a':>7}")
    for key in ("wall_s", "stereo_job_s_later", "fusion_job_s_later"):
        a, b = med("a", key), med("b", key)
        print(f"{key + ' (median)':28} {a:>24} {b:>30} {b / a:>7.2f}")
    for key in ("flicker_mm", "moving_acc_mm", "box_acc_median_mm", "box_acc_p90_mm",
                "completeness10", "completeness20"):
        a, b = scores["a"][key], scores["b"][key]
        print(f"{key:28} {a:>24} {b:>30} {b / a if a else float('nan'):>7.2f}")


if __name__ == "__main__":
    sys.exit(main())
