#!/usr/bin/env bash
# LAMMPS side of the Sable DEM peer benchmarks (see README.md): the periodic gas
# (in.sable_bench: 20,000 spheres, 2000 steps) and the twins of the suite's other
# scenes (in.<scene>).
#
# Usage: [SCENE=name] run_lammps.sh [DATA_FILE]
#
# DATA_FILE (or env SABLE_LAMMPS_DATA): data file to run. For the gas, default
#   $OUT_DIR/data.sable_bench, generated with gen_data.py if missing; pass the
#   file written by `sable bench dem --lammps-data FILE` to run Sable's own
#   initial state. For the other scenes it is required: the file written by
#   `sable bench dem --scene NAME --lammps-data FILE`, with FILE.vars beside it
#   (the scene's parameters, steps included).
#
# Environment knobs (all optional):
#   SCENE     gas (default), deposition_3d, shear_3d, deposition_2d, biaxial_2d,
#             polydisperse_3d
#   NEIGHBOR  neighbour list style of the suite inputs (default bin; multi bins
#             each size class apart)
#   OUT_DIR   logs + generated data   (default ${TMPDIR:-/tmp}/sable-bench-lammps)
#   MODES     runs to do, in order    (default "serial mpi2 omp2"; unsupported ones are skipped)
#   REPEATS   timings per mode        (default 2)
#   NSTEPS    steps per run           (default 2000)
#   N, SEED   passed to gen_data.py   (default 20000, 42)
#   DIAG      1 = thermo also reports rotational KE + contact count (default 1;
#             costs an extra neighbour pass at each of the 5 thermo steps)
#   LIMIT_DAMPING 1 = clip normal contact force at zero (pair keyword limit_damping; default 0)
#   LMP       LAMMPS binary           (default: first of lmp, lmp_serial, lmp_mpi on PATH)
#   MPIRUN    MPI launcher            (default: mpirun)
#
# Output: one JSON line per run on stdout (also appended to $OUT_DIR/results.jsonl);
# progress and notes on stderr. LAMMPS logs: $OUT_DIR/log.<mode>_r<repeat>.lammps.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
OUT_DIR="${OUT_DIR:-${TMPDIR:-/tmp}/sable-bench-lammps}"
SCENE="${SCENE:-gas}"
NEIGHBOR="${NEIGHBOR:-bin}"
MODES="${MODES:-serial mpi2 omp2}"
REPEATS="${REPEATS:-2}"
NSTEPS="${NSTEPS:-2000}"
N="${N:-20000}"
SEED="${SEED:-42}"
DIAG="${DIAG:-1}"
LIMIT_DAMPING="${LIMIT_DAMPING:-0}"
MPIRUN="${MPIRUN:-mpirun}"
PY="${PYTHON:-python3}"
mkdir -p "$OUT_DIR"

note() { echo "run_lammps: $*" >&2; }

# --- LAMMPS binary and its capabilities -------------------------------------
if [[ -z "${LMP:-}" ]]; then
  for c in lmp lmp_serial lmp_mpi; do
    if command -v "$c" >/dev/null 2>&1; then LMP="$c"; break; fi
  done
fi
if [[ -z "${LMP:-}" ]]; then
  note "no LAMMPS binary found (apt-get install -y lammps)"; exit 1
fi
HELP="$("$LMP" -h 2>/dev/null || true)"
LMP_VERSION="$(printf '%s\n' "$HELP" | sed -n 's/^Large-scale Atomic\/Molecular Massively Parallel Simulator - //p' | head -n1)"
PKGS="$(printf '%s\n' "$HELP" | sed -n '/^Installed packages:/,/^List of individual style/p')"
has_pkg() { printf '%s\n' "$PKGS" | tr ' ' '\n' | grep -qx "$1"; }
if ! has_pkg GRANULAR; then note "$LMP lacks the GRANULAR package (pair gran/hooke/history)"; exit 1; fi
note "LAMMPS: $LMP, version '$LMP_VERSION'"

TIME_BIN=""
if [[ -x /usr/bin/time ]]; then TIME_BIN=/usr/bin/time; else note "/usr/bin/time missing: no max-RSS numbers"; fi

MPI_FLAGS=()
if [[ "$(id -u)" == 0 ]]; then MPI_FLAGS+=(--allow-run-as-root); fi

# --- data file ----------------------------------------------------------------
DATA="${1:-${SABLE_LAMMPS_DATA:-}}"
if [[ -z "$DATA" && "$SCENE" != gas ]]; then
  note "SCENE=$SCENE needs the data file of sable bench dem --scene $SCENE --lammps-data FILE"; exit 2
fi
if [[ -z "$DATA" ]]; then
  DATA="$OUT_DIR/data.sable_bench"
  if [[ ! -s "$DATA" ]]; then
    "$PY" "$HERE/gen_data.py" --out "$DATA" --n "$N" --seed "$SEED"
  fi
fi
[[ -s "$DATA" ]] || { note "data file '$DATA' missing or empty"; exit 1; }
DATA="$(cd "$(dirname "$DATA")" && pwd)/$(basename "$DATA")"
note "data: $DATA"

# Peak RSS of an idle LAMMPS process (empty input): binary + libraries, no atoms.
RSS_BASE_KB=""
if [[ -n "$TIME_BIN" ]]; then
  : > "$OUT_DIR/empty.in"
  RSS_BASE_KB="$("$TIME_BIN" -f %M "$LMP" -in "$OUT_DIR/empty.in" -log none -nocite -screen none 2>&1 >/dev/null | tail -n1)"
  note "idle LAMMPS process max RSS: ${RSS_BASE_KB} kB"
fi

if [[ "$SCENE" == gas ]]; then
  LMP_ARGS=(-in "$HERE/in.sable_bench" -var data "$DATA" -var nsteps "$NSTEPS" -var diag "$DIAG" -var limit "$LIMIT_DAMPING" -nocite -screen none)
else
  [[ -f "$HERE/in.$SCENE" ]] || { note "no LAMMPS twin for scene '$SCENE' ($HERE/in.$SCENE)"; exit 2; }
  [[ -s "$DATA.vars" ]] || { note "$DATA.vars missing: write it with sable bench dem --lammps-data"; exit 2; }
  LMP_ARGS=(-in "$HERE/in.$SCENE" -var data "$DATA" -var peers "$HERE" -var neighbor_style "$NEIGHBOR" -nocite -screen none)
  LIMIT_DAMPING=1  # the twins of the suite floor the normal force, as Sable does by default
fi

# --- one run ----------------------------------------------------------------
# run_one MODE RANKS THREADS REPEAT
run_one() {
  local mode="$1" ranks="$2" threads="$3" rep="$4"
  local tag="${mode}_r${rep}"
  local log="$OUT_DIR/log.$tag.lammps" rss="$OUT_DIR/rss.$tag"
  rm -f "$log" "$rss".*
  local cmd=()
  local extra=()
  if [[ "$mode" == omp* ]]; then extra=(-sf omp -pk omp "$threads"); fi
  if [[ "$ranks" -gt 1 ]]; then
    cmd=("$MPIRUN" "${MPI_FLAGS[@]}" -np "$ranks")
    if [[ -n "$TIME_BIN" ]]; then
      # Wrap each rank so every rank's max RSS lands in its own file.
      cmd+=(sh -c 'exec '"$TIME_BIN"' -f %M -o "$0.${OMPI_COMM_WORLD_RANK:-${PMI_RANK:-x}}" "$@"' "$rss")
    fi
  elif [[ -n "$TIME_BIN" ]]; then
    cmd=("$TIME_BIN" -f %M -o "$rss.0")
  fi
  cmd+=("$LMP" "${extra[@]}" "${LMP_ARGS[@]}" -log "$log")
  local load; load="$(cut -d' ' -f1 /proc/loadavg 2>/dev/null || echo '')"
  note "[$tag] load=$load OMP_NUM_THREADS=$threads ${cmd[*]}"
  OMP_NUM_THREADS="$threads" "${cmd[@]}" >/dev/null
  "$PY" - "$log" "$mode" "$ranks" "$threads" "$rep" "$LMP_VERSION" "$DATA" "$rss" "$RSS_BASE_KB" "$load" "$LIMIT_DAMPING" "$SCENE" "$NEIGHBOR" <<'PYEOF' | tee -a "$OUT_DIR/results.jsonl"
import glob, json, re, sys
log, mode, ranks, threads, rep, version, data, rss, rss_base, load, limit, scene, neighbor = sys.argv[1:14]
rss_base = int(rss_base) if rss_base.strip().isdigit() else None
ranks, threads, rep = int(ranks), int(threads), int(rep)
text = open(log).read()
# The input does "run 0" (mass check) then the timed run: use the last run's lines.
loops = re.findall(r"Loop time of (\S+) on (\d+) procs for (\d+) steps with (\d+) atoms", text)
loop, procs, steps, atoms = float(loops[-1][0]), int(loops[-1][1]), int(loops[-1][2]), int(loops[-1][3])
mem = re.findall(r"Per MPI rank memory allocation \(min/avg/max\) = (\S+) \| (\S+) \| (\S+) Mbytes", text)
mem_min, mem_avg, mem_max = (float(x) for x in mem[-1])
neighs = re.findall(r"Total # of neighbors = (\d+)", text)
ave = re.findall(r"Ave neighs/atom = (\S+)", text)
builds = re.findall(r"Neighbor list builds = (\d+)", text)
dangerous = re.findall(r"Dangerous builds = (\d+)", text)
# (the log also echoes the input's print command itself: take the last match)
mass = re.findall(r"^SABLE_MASS min=(\S+) max=(\S+) total=(\S+)", text, re.M)
# Thermo of the timed run: rows after the last header starting with "Step".
lines = text.splitlines()
hdr = max(i for i, l in enumerate(lines) if l.split()[:1] == ["Step"])
cols = lines[hdr].split()
thermo = []
for l in lines[hdr + 1:]:
    f = l.split()
    if len(f) != len(cols) or not f[0].isdigit():
        break
    thermo.append(dict(zip(cols, (float(x) for x in f))))
rss_kb = []
for p in sorted(glob.glob(rss + ".*")):
    try:
        rss_kb.append(int(open(p).read().split()[-1]))
    except (ValueError, IndexError):
        pass
out = {
    "code": "lammps",
    "scene": scene,
    "neighbor": neighbor,
    "mode": mode,
    "particles": atoms,
    "steps": steps,
    "threads": procs * threads,
    "mpi_ranks": procs,
    "omp_threads": threads,
    "repeat": rep,
    "wall_seconds": loop,
    "particle_steps_per_second": atoms * steps / loop,
    # LAMMPS's own accounting (sum over ranks of its per-rank allocation).
    "bytes_per_particle": mem_avg * procs * 1024 * 1024 / atoms,
    "lammps_mbytes_per_rank_max": mem_max,
    # Peak resident set size of the process(es), incl. binary/MPI libraries.
    "max_rss_bytes": sum(rss_kb) * 1024 if rss_kb else None,
    "rss_bytes_per_particle": sum(rss_kb) * 1024 / atoms if rss_kb else None,
    # Same, less an idle LAMMPS process's RSS per rank: what the particles cost.
    "rss_net_bytes_per_particle": (sum(rss_kb) - rss_base * len(rss_kb)) * 1024 / atoms
        if rss_kb and rss_base is not None else None,
    "total_neighbors": int(neighs[-1]) if neighs else None,
    "ave_neighs_per_atom": float(ave[-1]) if ave else None,
    "neighbor_list_builds": int(builds[-1]) if builds else None,
    "dangerous_builds": int(dangerous[-1]) if dangerous else None,
    "mass_each_kg": float(mass[-1][1]) if mass else None,
    "thermo": [
        {k: (int(round(v)) if k in ("Step", "Atoms", "v_contacts") else v) for k, v in row.items()
         if k != "CPU"}
        for row in thermo
    ],
    "limit_damping": limit == "1",
    "loadavg_1min_before": float(load) if load else None,
    "lammps_version": version,
    "data": data,
    "log": log,
}
print(json.dumps(out))
PYEOF
}

for mode in $MODES; do
  case "$mode" in
    serial) ranks=1; threads=1 ;;
    mpi[0-9]*) ranks="${mode#mpi}"; threads=1
      if ! command -v "$MPIRUN" >/dev/null 2>&1; then note "skip $mode: no $MPIRUN"; continue; fi ;;
    omp[0-9]*) ranks=1; threads="${mode#omp}"
      if ! has_pkg OPENMP; then note "skip $mode: this LAMMPS build has no OPENMP package (-sf omp unavailable)"; continue; fi ;;
    *) note "unknown mode '$mode' (use serial, mpiN, ompN)"; exit 2 ;;
  esac
  for rep in $(seq 1 "$REPEATS"); do
    run_one "$mode" "$ranks" "$threads" "$rep"
  done
done
