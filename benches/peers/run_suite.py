#!/usr/bin/env python3
"""Sable against LAMMPS on the DEM benchmark suite, side by side, alternated.

For each scene: `sable bench dem --scene NAME --lammps-data` writes the timed scene's initial
state and parameters (running the untimed preparation first, cached); then each round runs, in
turn, Sable on 1 thread, LAMMPS serial, Sable on 2 threads and LAMMPS on 2 MPI ranks, so that
the VM's drifting speed hits both codes alike. Every run's JSON line goes to OUT/results.jsonl;
the summary (median particle-steps per second, ratio per round, memory, final state) is printed
as a Markdown table and written to OUT/summary.json.

Usage: run_suite.py [--sable PATH] [--scenes a,b] [--rounds N] [--out DIR] [--particles N]
                    [--steps N] [--neighbor-multi]
Needs LAMMPS (`apt-get install lammps`: lmp and mpirun) and Python 3 (standard library).
"""

import argparse
import json
import os
import statistics
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
SUITE = ["gas", "deposition_3d", "shear_3d", "deposition_2d", "biaxial_2d", "polydisperse_3d"]


def log(msg):
    print(f"run_suite: {msg}", file=sys.stderr, flush=True)


def sable(args, scene, threads, data=None):
    cmd = [args.sable, "bench", "dem", "--scene", scene, "--threads", str(threads), "--json"]
    if args.particles:
        cmd += ["--particles", str(args.particles)]
    if args.steps:
        cmd += ["--steps", str(args.steps)]
    if data:
        cmd += ["--lammps-data", data]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    r = json.loads(out.strip().splitlines()[-1])
    r["code"] = "sable"
    return r


def lammps(args, scene, mode, data):
    env = dict(os.environ, SCENE=scene, MODES=mode, REPEATS="1", OUT_DIR=os.path.join(args.out, "lammps"))
    if args.neighbor_multi:
        env["NEIGHBOR"] = "multi"
    out = subprocess.run(["bash", os.path.join(HERE, "run_lammps.sh"), data], check=True, capture_output=True, text=True, env=env).stdout
    return json.loads(out.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sable", default=os.path.join(HERE, "..", "..", "target", "release", "sable"))
    ap.add_argument("--scenes", default=",".join(SUITE))
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(os.environ.get("TMPDIR", "/tmp"), "sable-suite"))
    ap.add_argument("--particles", type=int)
    ap.add_argument("--steps", type=int)
    ap.add_argument("--neighbor-multi", action="store_true", help="LAMMPS bins each size class apart (neighbor multi)")
    ap.add_argument("--threads", default="1,2", help="thread counts to run (1,2)")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    threads = [int(t) for t in args.threads.split(",")]
    results_path = os.path.join(args.out, "results.jsonl")
    summary = {}
    for scene in args.scenes.split(","):
        data = os.path.join(args.out, f"data.{scene}")
        log(f"{scene}: writing the initial state ({data})")
        # The run that writes the data is the first round's Sable run on the first thread count.
        first = sable(args, scene, threads[0], data)
        runs = {(code, t): [] for code in ("sable", "lammps") for t in threads}
        for k in range(args.rounds):
            for t in threads:
                r = first if (k, t) == (0, threads[0]) else sable(args, scene, t)
                runs[("sable", t)].append(r)
                log(f"{scene} round {k + 1}: sable {t} thread(s) {r['particle_steps_per_second']:.3e} particle-steps/s")
                mode = "serial" if t == 1 else f"mpi{t}"
                r = lammps(args, scene, mode, data)
                runs[("lammps", t)].append(r)
                log(f"{scene} round {k + 1}: lammps {mode} {r['particle_steps_per_second']:.3e} particle-steps/s")
        with open(results_path, "a") as f:
            for rs in runs.values():
                for r in rs:
                    f.write(json.dumps(r) + "\n")
        s = {}
        for t in threads:
            sr = [r["particle_steps_per_second"] for r in runs[("sable", t)]]
            lr = [r["particle_steps_per_second"] for r in runs[("lammps", t)]]
            ratios = [a / b for a, b in zip(sr, lr)]
            s[t] = {
                "sable": {"min": min(sr), "median": statistics.median(sr), "max": max(sr),
                          "bytes_per_particle": runs[("sable", t)][-1]["bytes_per_particle"]},
                "lammps": {"min": min(lr), "median": statistics.median(lr), "max": max(lr),
                           "bytes_per_particle": runs[("lammps", t)][-1]["bytes_per_particle"]},
                "ratio_per_round": ratios,
                "ratio_of_medians": statistics.median(sr) / statistics.median(lr),
            }
        if 1 in threads and 2 in threads:
            s["sable_speedup_2_threads"] = s[2]["sable"]["median"] / s[1]["sable"]["median"]
            s["lammps_speedup_2_ranks"] = s[2]["lammps"]["median"] / s[1]["lammps"]["median"]
        last_l = runs[("lammps", threads[0])][-1]
        thermo = last_l.get("thermo") or [{}]
        s["end"] = {"sable": first.get("end"), "lammps": thermo[-1], "particles": first["particles"], "steps": first["steps"]}
        summary[scene] = s
        with open(os.path.join(args.out, "summary.json"), "w") as f:
            json.dump(summary, f, indent=1)
    print("| scene | particles × steps | cores | Sable particle-steps/s (median) | LAMMPS | Sable/LAMMPS per round (median) | Sable B/particle |")
    print("|---|---|---|---|---|---|---|")
    for scene, s in summary.items():
        for t in threads:
            x = s[t]
            rs = x["ratio_per_round"]
            print(f"| {scene} | {s['end']['particles']:,} × {s['end']['steps']:,} | {t} | {x['sable']['median']:.3e} | {x['lammps']['median']:.3e} | "
                  f"{min(rs):.2f}–{max(rs):.2f} ({statistics.median(rs):.2f}) | {x['sable']['bytes_per_particle']:.0f} |")


if __name__ == "__main__":
    main()
