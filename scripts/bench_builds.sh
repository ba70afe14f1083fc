#!/usr/bin/env bash
# Side-by-side timing of builds of the solver (part of `make bench`): the reference run (0.55
# chain, 50 cylinders, mu = 6 kg/s, v0 = 1.3 m/s, 1 ms, DOP853 rtol 5e-8 with predict_switches;
# a baseline revision older than that option runs it without) and the right-hand side,
# for
#   default    this tree, built as a user builds it (no special flags: run-time CPU dispatch)
#   portable   the same binary pinned to the no-FMA code path (CHAINSWEEP_CPU=portable)
#   native     this tree built with RUSTFLAGS="-C target-cpu=native" (target/bench-native)
#   baseline   optional: another revision (BENCH_BASELINE=REV, e.g. the tag first-release),
#              exported with `git archive` into target/bench-baseline and built with its own
#              settings
# The builds run in alternation, ROUNDS times, each time REPEATS reference runs in one process; a
# round's median goes into the table, which gives the median and the minimum over the rounds (the
# machine is shared: alternation spreads its load over every build alike).
#
#   scripts/bench_builds.sh                        # default, portable, native
#   BENCH_BASELINE=first-release scripts/bench_builds.sh # ... and the first release's build
set -euo pipefail
cd "$(dirname "$0")/.."

CARGO=${CARGO:-cargo}
ROUNDS=${ROUNDS:-7}
REPEATS=${REPEATS:-30}
RTOL=5e-8
TARGET=${CARGO_TARGET_DIR:-$PWD/target}
EXAMPLES=(--example refrun --example rhs_timing)

build() { # build DIR TARGET_DIR [RUSTFLAGS]
  (cd "$1" && CARGO_TARGET_DIR="$2" RUSTFLAGS="${3:-}" \
    $CARGO build --quiet --release -p chainsweep-solver "${EXAMPLES[@]}")
}

names=(default portable native)
bins=("$TARGET/release/examples" "$TARGET/release/examples" "$TARGET/bench-native/release/examples")
envs=("" "CHAINSWEEP_CPU=portable" "")

echo "building: default"
build . "$TARGET"
echo "building: native (-C target-cpu=native)"
build . "$TARGET/bench-native" "-C target-cpu=native"
if [[ -n "${BENCH_BASELINE:-}" ]]; then
  src="$TARGET/bench-baseline/src-$BENCH_BASELINE"
  if [[ ! -d "$src" ]]; then
    echo "exporting baseline $BENCH_BASELINE"
    mkdir -p "$src"
    git archive "$BENCH_BASELINE" | tar -x -C "$src"
  fi
  echo "building: baseline $BENCH_BASELINE (its own .cargo settings)"
  # The baseline's own flags (its .cargo/config.toml), not this shell's.
  (cd "$src" && env -u RUSTFLAGS CARGO_TARGET_DIR="$TARGET/bench-baseline/target" \
    $CARGO build --quiet --release -p chainsweep-solver "${EXAMPLES[@]}")
  names+=("baseline-$BENCH_BASELINE")
  bins+=("$TARGET/bench-baseline/target/release/examples")
  envs+=("")
fi

declare -A medians mins
for ((r = 1; r <= ROUNDS; r++)); do
  for i in "${!names[@]}"; do
    line=$(env ${envs[$i]} "${bins[$i]}/refrun" "$RTOL" "$REPEATS" predict)
    medians[$i]+="$(sed -n 's/.*median \([0-9.]*\) ms.*/\1/p' <<<"$line") "
    mins[$i]+="$(sed -n 's/.*min \([0-9.]*\) ms.*/\1/p' <<<"$line") "
    if ((r == 1)); then echo "${names[$i]}: $line"; fi
  done
done

echo
echo "reference run, DOP853 rtol $RTOL, predict_switches: $ROUNDS rounds x $REPEATS runs, alternating builds"
echo "(median: of the rounds' medians; min: fastest single run, the least disturbed by other load)"
printf '%-20s %10s %10s %10s %10s   %s\n' build "median ms" "/default" "min ms" "/default" \
  "right-hand side (min of 30 x 20 000 calls)"
base_med="" base_min=""
stat() { tr ' ' '\n' <<<"$1" | grep . | sort -g | awk -v q="$2" '{a[NR]=$1} END {print (q == "min") ? a[1] : a[int((NR+1)/2)]}'; }
for i in "${!names[@]}"; do
  med=$(stat "${medians[$i]}" median)
  min=$(stat "${mins[$i]}" min)
  [[ -z "$base_med" ]] && base_med=$med && base_min=$min
  rhs=$(env ${envs[$i]} "${bins[$i]}/rhs_timing" | sed -n 's/^full physics.*: \(.*\) per evaluation, \(.*\) per contact/\1, \2 per contact/p')
  printf '%-20s %10s %10s %10s %10s   %s\n' "${names[$i]}" "$med" \
    "$(awk -v a="$med" -v b="$base_med" 'BEGIN {printf "%.2f", a / b}')" "$min" \
    "$(awk -v a="$min" -v b="$base_min" 'BEGIN {printf "%.2f", a / b}')" "$rhs"
done
