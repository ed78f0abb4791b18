#!/usr/bin/env bash
# Fabrica against LIGGGHTS and LAMMPS on large specimens: the shared dense-13584 packing tiled
# 1x1x1, 2x2x2 and 4x4x4 (13,584 / 108,672 / 869,376 spheres, benchmarks/make_tiled.py), the
# same contact law and time step as ../shared/bench/dense-13584, 1 and 2 ranks, one sitting.
#
#   REPS=3 STEPS=200 SIZES="1 2 4" benchmarks/run-large.sh
#
# Each of the REPS rounds runs, back to back for every size: Fabrica (bench_scaling strong, one
# repetition; the serial code on 1 rank, the MPI domain on 2), then LIGGGHTS and LAMMPS with
# the shared decks on the tiled file. Every figure is loop time / (N x steps) in microseconds
# per particle-step (set-up excluded in all three), the peak resident memory of each rank
# (/usr/bin/time around every rank; the largest rank's), and, for Fabrica on 2 ranks, the
# bytes each rank sends per step (ghost updates, migrations and ghost builds). Medians over
# the rounds, and the ratios Fabrica / peer. The peers come from Debian's packages
# (apt-get install lammps liggghts); without them only Fabrica runs.
#
# Environment: REPS (3), STEPS (200), SIZES ("1 2 4"), RANKS ("1 2"), BUILD (build-bench at
# the repository root), WORK (BUILD/large: the tiled files, about 85 MB for 4x4x4), PEERS (1).
set -euo pipefail
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
REPS=${REPS:-3}
STEPS=${STEPS:-200}
SIZES=${SIZES:-1 2 4}
RANKS=${RANKS:-1 2}
BUILD=${BUILD:-$root/build-bench}
[ -d "$BUILD" ] && BUILD=$(cd "$BUILD" && pwd)  # absolute: the scenes name their data files by it
WORK=${WORK:-$BUILD/large}
PEERS=${PEERS:-1}
shared=$(cd "$root/../shared/bench/dense-13584" && pwd)
bench=$BUILD/benchmarks/bench_scaling
[ -x "$bench" ] || { echo "no $bench: cmake -S . -B build-bench -DFABRICA_TESTS=OFF && make -C build-bench -j2 bench_scaling" >&2; exit 1; }
have_lmp=0; have_lig=0
if [ "$PEERS" = 1 ]; then
  command -v lmp >/dev/null && have_lmp=1
  command -v liggghts >/dev/null && have_lig=1
fi
mkdir -p "$WORK"
WORK=$(cd "$WORK" && pwd)
results=$WORK/results.txt
: > "$results"

# The tiled files and, per size, a Fabrica scene and a peer directory with the shared decks.
for s in $SIZES; do
  d=$WORK/tiled-$s
  mkdir -p "$d"
  [ -s "$d/dense.data" ] || /usr/bin/python3 "$here/make_tiled.py" "$s" "$d/dense.data" "$shared/dense.data"
  sed -e "s#^file = .*#file = \"$d/dense.data\"#" -e "s/^steps = .*/steps = $STEPS/" \
      -e "s/^output_every = .*/output_every = $STEPS/" "$here/dense-13584.toml" > "$d/scene.toml"
  for f in params.in contact_lammps.in contact_liggghts.in neigh_bin.in; do cp "$shared/$f" "$d/"; done
  for f in bench_lammps.in bench_liggghts.in; do
    sed -e "s/^run  *2000/run             $STEPS/" -e '/^# --- diagnostics/,$d' "$shared/$f" > "$d/$f"
  done
done

n_of() { grep -m1 ' atoms$' "$WORK/tiled-$1/dense.data" | awk '{print $1}'; }
# Peak RSS (KB) of the largest rank, from the /usr/bin/time lines "RSS <kb>".
peak() { grep -h '^RSS ' "$@" | awk '{if ($2 > m) m = $2} END {print m + 0}'; }

echo "large specimens side by side, $(date -u '+%Y-%m-%d %H:%M UTC'), $(lscpu | sed -n 's/^Model name: *//p'), $(nproc) cores, $STEPS steps"
echo "Fabrica $(git -C "$root" describe --always --dirty 2>/dev/null || echo '?'); LAMMPS $have_lmp, LIGGGHTS $have_lig"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Runs one rank under /usr/bin/time, its peak RSS into $tmp/rss.<rank>.
cat > "$tmp/rss" <<WRAP
#!/usr/bin/env bash
exec /usr/bin/time -f 'RSS %M' -o "$tmp/rss.\${OMPI_COMM_WORLD_RANK:-0}" "\$@"
WRAP
chmod +x "$tmp/rss"
for rep in $(seq 1 "$REPS"); do
  for s in $SIZES; do
    d=$WORK/tiled-$s; n=$(n_of "$s")
    for np in $RANKS; do
      rm -f "$tmp"/rss.*
      mpirun --oversubscribe -np "$np" "$tmp/rss" "$bench" strong 1 "$STEPS" "$d/scene.toml" > "$tmp/fab" 2>&1 \
        || { cat "$tmp/fab"; exit 1; }
      us=$(sed -n 's/^RESULT .*us_per_particle_step_median=\([0-9.]*\).*/\1/p' "$tmp/fab")
      bytes=$(sed -n 's/^RESULT .*bytes_per_rank_step=\([0-9.]*\).*/\1/p' "$tmp/fab")
      echo "size=$s n=$n ranks=$np rep=$rep engine=fabrica us=$us rss_kb=$(peak "$tmp"/rss.*) bytes_per_rank_step=$bytes" | tee -a "$results"
      if [ $have_lig = 1 ]; then
        rm -f "$tmp"/rss.*
        (cd "$d" && mpirun --oversubscribe -np "$np" "$tmp/rss" liggghts -in bench_liggghts.in -log "$tmp/lig.log" -screen none)
        us=$(awk -v n="$n" -v s="$STEPS" '/^Loop time of/ {printf "%.4f\n", $4*1e6/(n*s); exit}' "$tmp/lig.log")
        echo "size=$s n=$n ranks=$np rep=$rep engine=liggghts us=$us rss_kb=$(peak "$tmp"/rss.*)" | tee -a "$results"
      fi
      if [ $have_lmp = 1 ]; then
        rm -f "$tmp"/rss.*
        (cd "$d" && mpirun --oversubscribe -np "$np" "$tmp/rss" lmp -in bench_lammps.in -var neigh bin -log "$tmp/lmp.log" -screen none)
        us=$(awk -v n="$n" -v s="$STEPS" '/^Loop time of/ {printf "%.4f\n", $4*1e6/(n*s); exit}' "$tmp/lmp.log")
        echo "size=$s n=$n ranks=$np rep=$rep engine=lammps us=$us rss_kb=$(peak "$tmp"/rss.*)" | tee -a "$results"
      fi
    done
  done
done

# Medians per (size, ranks, engine), then ratios to the peers.
echo
echo "medians over $REPS round(s): us per particle-step, peak RSS per rank (MB, bytes per particle on that rank's share)"
/usr/bin/python3 - "$results" <<'PY'
import sys, statistics as st
rows = [dict(kv.split("=", 1) for kv in line.split()) for line in open(sys.argv[1]) if line.strip()]
keys = sorted({(int(r["size"]), int(r["ranks"]), r["engine"]) for r in rows})
med = {}
for k in keys:
    sel = [r for r in rows if (int(r["size"]), int(r["ranks"]), r["engine"]) == k]
    us = st.median(float(r["us"]) for r in sel)
    kb = st.median(float(r["rss_kb"]) for r in sel)
    n = int(sel[0]["n"])
    med[k] = (us, kb)
    extra = ""
    if "bytes_per_rank_step" in sel[0] and sel[0]["bytes_per_rank_step"]:
        extra = f", {st.median(float(r['bytes_per_rank_step']) for r in sel) / 1024:.1f} KB sent per rank per step"
    print(f"  {n:>9} spheres, {k[1]} rank(s), {k[2]:9}: {us:.4f} us, {kb / 1024:.0f} MB "
          f"({kb * 1024 / (n / k[1]):.0f} B per particle){extra}")
for (s, np_, e), (us, kb) in sorted(med.items()):
    if e != "fabrica":
        continue
    for peer in ("liggghts", "lammps"):
        if (s, np_, peer) in med:
            pus, pkb = med[(s, np_, peer)]
            print(f"  tile {s}^3, {np_} rank(s): Fabrica / {peer}: time {us / pus:.2f}, memory {kb / pkb:.2f}")
base = {np_: med[(s, np_, "fabrica")][0] for (s, np_, e) in med if e == "fabrica" and s == 1}
for (s, np_, e), (us, kb) in sorted(med.items()):
    if e == "fabrica" and s != 1 and np_ in base:
        print(f"  Fabrica, {np_} rank(s): cost per particle at tile {s}^3 / tile 1: {us / base[np_]:.2f}")
PY
