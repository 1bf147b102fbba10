#!/bin/bash
# Lists the panic call sites that survive in the firmware image for TARGET, each at the
# innermost source line of this repository (see docs/EMBEDDED.md, "Panics").
# usage: firmware/tools/panic_sites.sh thumbv7em-none-eabihf     (from the repository root;
# needs llvm-nm, llvm-objdump and llvm-addr2line)
set -u
target=${1:?usage: $0 TARGET}
root=$(pwd)
CARGO_PROFILE_FIRMWARE_DEBUG=line-tables-only CARGO_PROFILE_FIRMWARE_STRIP=none \
    RUSTFLAGS="-D warnings" cargo build -q -p lfdepth-firmware --profile firmware \
    --target "$target" --target-dir target/nostd-lines ${FEATURES:+--features "$FEATURES"} || exit 1
image=target/nostd-lines/$target/firmware/lfdepth-firmware
panics=$(llvm-nm "$image" | grep -E "panic|slice_.*_fail|len_mismatch_fail|unwrap_failed|expect_failed" \
    | awk '{print $1}' | sed 's/^0*//' | paste -sd'|')
sites=$(llvm-objdump -d --no-show-raw-insn "$image" \
    | grep -E "\sb(l|\.w|)\s+0x($panics)\b" | awk '{print $1}' | tr -d ':')
echo "$(echo "$sites" | grep -c .) call sites of panic functions in $image"
for site in $sites; do
    llvm-addr2line -e "$image" -i -f -C "0x$site" | paste - - \
        | grep "$root" | grep -v ":0$" | head -1 | awk -F'\t' '{print $2}'
done | sed "s|$root/||" | sort | uniq -c | sort -k2
