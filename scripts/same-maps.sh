#!/usr/bin/env bash
# Checks that two builds of `lfdepth` write byte-identical maps: the default pipeline,
# Q16.16, the EPI stage alone, the fast preset and TV sweeps on the HCI scenes beside the
# repository (skipped, saying so, when ../shared/data is absent), every synthetic scene,
# and the alignment on a misaligned synthetic array.
#
#   scripts/same-maps.sh OLD_LFDEPTH NEW_LFDEPTH [WORKDIR]
#
# Build the old binary from the commit to compare with (`git worktree add`, then
# `cargo build --release -p lfdepth-cli`). Exits non-zero on the first difference.
set -euo pipefail
old=${1:?usage: same-maps.sh OLD_LFDEPTH NEW_LFDEPTH [WORKDIR]}
new=${2:?usage: same-maps.sh OLD_LFDEPTH NEW_LFDEPTH [WORKDIR]}
work=${3:-$(mktemp -d)}
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
data="$root/../shared/data/hci"
mkdir -p "$work/scenes" "$work/old" "$work/new"
failed=0
compare() { # NAME INPUT ARGS...
  local name=$1 input=$2
  shift 2
  "$old" estimate "$input" -o "$work/old/$name.pfm" --confidence "$work/old/$name.conf.pfm" "$@" >/dev/null 2>&1
  "$new" estimate "$input" -o "$work/new/$name.pfm" --confidence "$work/new/$name.conf.pfm" "$@" >/dev/null 2>&1
  if cmp -s "$work/old/$name.pfm" "$work/new/$name.pfm" &&
    cmp -s "$work/old/$name.conf.pfm" "$work/new/$name.conf.pfm"; then
    echo "same      $name"
  else
    echo "DIFFERENT $name"
    failed=1
  fi
}
for scene in planes slanted spheres occlusion thin low-texture mixed; do
  "$old" synth --scene "$scene" --size 96 --out "$work/scenes/$scene" >/dev/null
  compare "synth-$scene" "$work/scenes/$scene" --threads 2
done
"$old" synth --scene mixed --size 128 --misalign --out "$work/scenes/misaligned" >/dev/null
compare synth-misaligned-align-on "$work/scenes/misaligned" --align on
compare synth-mixed-q16 "$work/scenes/mixed" --scalar q16
compare synth-mixed-1-thread "$work/scenes/mixed" --threads 1
if [ -d "$data" ]; then
  for scene in training/cotton stratified/backgammon; do
    name=${scene#*/}
    compare "$name" "$data/$scene"
    compare "$name-q16" "$data/$scene" --scalar q16
    compare "$name-epi" "$data/$scene" --stage epi
    compare "$name-fast" "$data/$scene" --preset fast
    compare "$name-sweeps" "$data/$scene" --tv-sweeps 2
  done
else
  echo "SKIPPED: the HCI scenes ($data is absent)"
fi
[ "$failed" = 0 ] && echo "all maps identical" || { echo "maps differ"; exit 1; }
