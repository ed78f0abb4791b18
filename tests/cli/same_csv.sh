# Sourced by the ensemble checks: same A B succeeds when every CSV file under output directory A
# equals B's, byte for byte (summary.csv but its last column, the wall-clock seconds), and there
# are at least 5 of them.
same() {
  local a=$1 b=$2 f n=0
  for f in $(cd "$a" && find . -name '*.csv' | sort); do
    if [ "$(basename "$f")" = summary.csv ]; then
      cmp -s <(rev "$a/$f" | cut -d, -f2- | rev) <(rev "$b/$f" | cut -d, -f2- | rev) || { echo "DIFFERS: $a/$f $b/$f"; return 1; }
    else
      cmp -s "$a/$f" "$b/$f" || { echo "DIFFERS: $a/$f $b/$f"; return 1; }
    fi
    n=$((n + 1))
  done
  [ "$n" -ge 5 ] || { echo "only $n CSV files in $a"; return 1; }
  echo "same: $n CSV files of $a and $b"
}
