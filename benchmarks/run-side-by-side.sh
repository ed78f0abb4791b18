#!/usr/bin/env bash
# Fabrica against LAMMPS and LIGGGHTS on the shared dense-13584 scene, in one sitting.
#
#   REPS=5 benchmarks/run-side-by-side.sh            (about 1 minute per round)
#   MODEL=hertz_mindlin benchmarks/run-side-by-side.sh (the same with Hertz-Mindlin contacts)
#
# MODEL=linear (the default) runs benchmarks/dense-13584.toml against the shared decks;
# MODEL=hertz_mindlin runs benchmarks/dense-13584-hertz.toml against a copy of the shared
# directory whose contact_lammps.in and contact_liggghts.in are those of benchmarks/hertz/.
#
# Every 1-rank run is bound to core 0: the peers' by mpirun -np 1 (Open MPI binds a rank to a
# core), Fabrica's by taskset -c 0, so that no ratio is taken across two cores (on this kind of
# machine the same run measured 0.0616 against 0.0515 us on cores 0 and 1 in one sitting).
#
# Each of the REPS rounds runs, back to back: Fabrica's bench_dense (one repetition, 1 rank),
# Fabrica on 2 ranks (bench_scaling strong, MPI domain decomposition; skipped when
# bench_scaling is not built or FABRICA2=0), and the peers' own script
# ../shared/bench/dense-13584/run-peers.sh with REPS=1 (LAMMPS and LIGGGHTS, 1 rank then 2
# ranks). Alternating the engines spreads the machine's noise over all of them. Every figure is
# loop time / (N x steps) in microseconds per particle-step: the peers' "Loop time", Fabrica's
# timed step loop (setup excluded in both; on 2 ranks the slowest rank's loop).
#
# Then one diagnostics run of each peer (outside any timing) gives the end state to compare
# with Fabrica's: pressure, contact count, neighbour-list builds, translational kinetic energy.
#
# On a shared machine, QUIET=1 (the default) waits before each round, up to MAXWAIT seconds
# (300), until no other process is runnable (the running-task count of /proc/loadavg, sampled
# for 2 s); the load average at the start of each round is printed with its times.
#
# Environment: REPS (5), BUILD (build-bench at the repository root), PEERS (the shared bench
# directory), DIAG (1: run the diagnostics), QUIET (1), MAXWAIT (300), FABRICA2 (1), MODEL
# (linear).
set -euo pipefail
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
REPS=${REPS:-5}
BUILD=${BUILD:-$root/build-bench}
[ -d "$BUILD" ] && BUILD=$(cd "$BUILD" && pwd)  # absolute: the scenes name their data files by it
PEERS=${PEERS:-$(cd "$root/../shared/bench/dense-13584" && pwd)}
DIAG=${DIAG:-1}
QUIET=${QUIET:-1}
MAXWAIT=${MAXWAIT:-300}
FABRICA2=${FABRICA2:-1}
MODEL=${MODEL:-linear}
case "$MODEL" in
  linear) scene=$here/dense-13584.toml ;;
  hertz_mindlin) scene=$here/dense-13584-hertz.toml ;;
  *) echo "MODEL=$MODEL: linear or hertz_mindlin" >&2; exit 2 ;;
esac
bench=$BUILD/benchmarks/bench_dense
scaling=$BUILD/benchmarks/bench_scaling
[ -x "$scaling" ] || FABRICA2=0
[ -x "$bench" ] || { echo "no $bench: cmake -S . -B build-bench -DFABRICA_TESTS=OFF && make -C build-bench -j2 bench_dense" >&2; exit 1; }
[ -x "$PEERS/run-peers.sh" ] || { echo "no $PEERS/run-peers.sh" >&2; exit 1; }
N=13584 STEPS=2000

# True if no process but this shell was runnable in 5 samples over 2 s.
idle() {
  local a b c r rest k
  for k in 1 2 3 4 5; do
    read -r a b c r rest < /proc/loadavg
    [ "${r%/*}" -le 1 ] || return 1
    sleep 0.5
  done
}
wait_idle() {
  [ "$QUIET" = 1 ] || return 0
  local t0=$SECONDS
  until idle; do
    if [ $((SECONDS - t0)) -ge "$MAXWAIT" ]; then echo "(still busy after ${MAXWAIT} s: running anyway)"; return 0; fi
    sleep 3
  done
}

out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
if [ "$MODEL" = hertz_mindlin ]; then  # the peers' decks with the Hertz contact files
  cp -r "$PEERS" "$out/peers"
  cp "$here/hertz/contact_lammps.in" "$here/hertz/contact_liggghts.in" "$out/peers/"
  PEERS=$out/peers
fi
echo "dense-13584 ($MODEL) side by side, $(date -u '+%Y-%m-%d %H:%M UTC'), $(lscpu | sed -n 's/^Model name: *//p'), $(nproc) cores"
echo "Fabrica $(git -C "$root" describe --always --dirty 2>/dev/null || echo '?'), $bench"
echo "load before: $(uptime | sed 's/.*load average: //')"
for rep in $(seq 1 "$REPS"); do
  wait_idle
  echo "round $rep, load $(cut -d' ' -f1-3 /proc/loadavg)"
  taskset -c 0 "$bench" 1 0 "$scene" > "$out/fab.$rep"
  fab=$(sed -n 's/^RESULT .*us_per_particle_step_median=\([0-9.]*\).*/\1/p' "$out/fab.$rep")
  echo "ranks=1 rep=$rep fabrica_us=$fab" | tee -a "$out/times"
  if [ "$FABRICA2" = 1 ]; then
    fab2=$(mpirun -np 2 "$scaling" strong 1 "$STEPS" "$scene" | sed -n 's/^RESULT .*us_per_particle_step_median=\([0-9.]*\).*/\1/p')
    echo "ranks=2 rep=$rep fabrica_us=$fab2" | tee -a "$out/times"
  fi
  REPS=1 "$PEERS/run-peers.sh" | sed "s/rep=1/rep=$rep/" | tee -a "$out/times"
done
echo "load after: $(uptime | sed 's/.*load average: //')"

# Median, min and max of one engine's column at a rank count.
stats() {  # engine ranks
  sed -n "s/^ranks=$2 .*$1_us=\([0-9.]*\).*/\1/p" "$out/times" | sort -g |
    awk '{v[NR] = $1} END {if (NR == 0) {print "- - -"; exit}
         m = NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2; printf "%.4f %.4f %.4f\n", m, v[1], v[NR]}'
}
read -r fab_med fab_min fab_max < <(stats fabrica 1)
read -r fab2_med fab2_min fab2_max < <(stats fabrica 2)
ratio() { awk -v a="$1" -v b="$2" 'BEGIN {if (a + 0 > 0 && b + 0 > 0) printf "%.2f", a / b; else printf "-"}'; }
echo
echo "us per particle-step over $REPS rounds (median / min / max); ratio = Fabrica / peer at the"
echo "same rank count (below 1: Fabrica faster)"
printf "%-34s %-24s %-24s %-14s %s\n" "engine" "1 rank" "2 ranks" "ratio 1 rank" "ratio 2 ranks"
printf "%-34s %-24s %-24s %-14s %s\n" "Fabrica" "$fab_med / $fab_min / $fab_max" "$fab2_med / $fab2_min / $fab2_max" "(median, min)" "(median, min)"
for e in liggghts lammps; do
  read -r m1 n1 x1 < <(stats $e 1)
  read -r m2 n2 x2 < <(stats $e 2)
  name=$([ $e = liggghts ] && echo "LIGGGHTS-PUBLIC (bin, newton off)" || echo "LAMMPS (bin, newton on)")
  printf "%-34s %-24s %-24s %-14s %s\n" "$name" "$m1 / $n1 / $x1" "$m2 / $n2 / $x2" \
    "$(ratio "$fab_med" "$m1"), $(ratio "$fab_min" "$n1")" "$(ratio "$fab2_med" "$m2"), $(ratio "$fab2_min" "$n2")"
done
grep -h '^RESULT' "$out/fab.1"

[ "$DIAG" = 1 ] || exit 0
echo
echo "end state after $STEPS steps (one more run of each peer, outside the timing)"
(cd "$PEERS" && mpirun -np 1 lmp -in bench_lammps.in -var neigh bin -log "$out/lmp.log" -screen none)
# The LIGGGHTS deck prints no pressure: a copy of it adds the virial pressure to its
# diagnostics run (after the timed run, which is unchanged).
mkdir "$out/lig"
cp "$PEERS/dense.data" "$PEERS/params.in" "$PEERS/contact_liggghts.in" "$out/lig/"
sed 's/^thermo_style *custom step ke c_z$/compute t all temp\ncompute p all pressure t virial\nthermo_style custom step ke c_z c_p/' \
  "$PEERS/bench_liggghts.in" > "$out/lig/bench.in"
(cd "$out/lig" && mpirun -np 1 liggghts -in bench.in -log "$out/lig.log" -screen none)
# LAMMPS: "Step KinEng c_p c_z c_fab" then "2000 ke p z contacts"; LIGGGHTS: "Step KinEng z p".
lmp_row=$(awk '/^ *Step +KinEng +c_p/ {getline; print; exit}' "$out/lmp.log")
lig_row=$(awk '/^ *Step +KinEng +z/ {getline; print; exit}' "$out/lig.log")
lmp_p0=$(awk '/^ *Step +CPU +KinEng +Press/ {getline; print $4; exit}' "$out/lmp.log")
lmp_builds=$(sed -n 's/^Neighbor list builds = //p' "$out/lmp.log" | head -1)
lig_builds=$(sed -n 's/^Neighbor list builds = //p' "$out/lig.log" | head -1)
r=$(grep -h '^RESULT' "$out/fab.1")
val() { echo "$r" | sed -n "s/.* $1=\([^ ]*\).*/\1/p"; }
printf "%-10s %-14s %-14s %-9s %-10s %-14s\n" engine p_end_Pa p_step0_Pa contacts "nl builds" ke_trans_J
printf "%-10s %-14.8g %-14.8g %-9s %-10s %-14.6g\n" Fabrica "$(val p_Pa)" "$(val p0_Pa)" "$(val contacts)" \
  "$(val rebuilds)" "$(val ke_trans_J)"
set -- $lmp_row
printf "%-10s %-14.8g %-14.8g %-9s %-10s %-14.6g\n" LAMMPS "$3" "$lmp_p0" "$5" "$lmp_builds" "$2"
set -- $lig_row
printf "%-10s %-14.8g %-14s %-9s %-10s %-14.6g\n" LIGGGHTS "${4:-nan}" "-" \
  "$(awk -v z="$3" -v n=$N 'BEGIN {printf "%.0f", z * n / 2}')" "$lig_builds" "$2"
echo "(LAMMPS contacts: compute fabric; LIGGGHTS: contact/atom average x N / 2; LAMMPS p_step0 is"
echo " the thermo 'press' of step 0; builds: 'Neighbor list builds' of the timed run, Fabrica's"
echo " rebuilds in the loop; the peers' ke is translational only)"
