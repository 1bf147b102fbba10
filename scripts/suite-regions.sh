#!/usr/bin/env bash
# Scores one `lfdepth` build on the realistic synthetic suite, per scene and per region:
# BadPix0.07 and MSE×100 of the whole scene, then BadPix0.07 inside the masks `synth`
# writes beside each scene (receding floor, |∇d| > 0.02 px/px, dim surfaces, fine
# relief, thin structures), and the mean row. Writes the maps (PFM and PNG) to WORKDIR.
#
#   lfdepth synth --suite realistic --out SUITE
#   scripts/suite-regions.sh LFDEPTH SUITE [WORKDIR] [estimate flags…]
set -euo pipefail
bin=${1:?usage: suite-regions.sh LFDEPTH SUITE [WORKDIR] [estimate flags...]}
suite=${2:?usage: suite-regions.sh LFDEPTH SUITE [WORKDIR] [estimate flags...]}
work=${3:-$(mktemp -d)}
shift $(($# < 3 ? $# : 3))
mkdir -p "$work"
badpix() { # EST GT [MASK]
  local mask=()
  [ -n "${3:-}" ] && mask=(--mask "$3")
  "$bin" eval "$1" --gt "$2" "${mask[@]}" | awk -v k="$4" '$1 == k { print $2 }'
}
echo "| scene | BadPix0.07 | MSE×100 | floor | slope > 0.02 | dim | relief | thin |"
echo "|---|---|---|---|---|---|---|---|"
sums=(0 0 0 0 0 0 0)
counts=(0 0 0 0 0 0 0)
for dir in "$suite"/*/; do
  name=$(basename "$dir")
  [ -f "$dir/gt_disp_lowres.pfm" ] || continue
  est="$work/$name.pfm"
  "$bin" estimate "$dir" -o "$est" --png "$work/$name.png" "$@" >/dev/null 2>&1
  gt="$dir/gt_disp_lowres.pfm"
  row=("$(badpix "$est" "$gt" "" BadPix0.07)" "$(badpix "$est" "$gt" "" MSE×100)")
  for mask in floor slope dim relief thin; do
    m="$dir/mask_$mask.png"
    value=$(badpix "$est" "$gt" "$m" BadPix0.07 2>/dev/null || true)
    row+=("${value:-–}")
  done
  printf '| %s |' "$name"
  for k in "${!row[@]}"; do
    printf ' %s |' "${row[$k]}"
    if [[ ${row[$k]} =~ ^[0-9.]+$ ]]; then
      sums[$k]=$(awk -v a="${sums[$k]}" -v b="${row[$k]}" 'BEGIN { print a + b }')
      counts[$k]=$((counts[$k] + 1))
    fi
  done
  echo
done
# Region columns average over the scenes that have that region.
printf '| **mean** |'
for k in 0 1 2 3 4 5 6; do
  awk -v s="${sums[$k]}" -v n="${counts[$k]}" 'BEGIN { if (n > 0) printf " %.3f |", s / n; else printf " – |" }'
done
echo
