#!/usr/bin/env bash
# The controller's budgets, for each board: static RAM, stack high-water mark, flash for code
# and for the map, and instructions per scan per stage. Builds what it needs; runs the bench
# and the controller (against the LMS5xx emulator) under QEMU mps2-an386, whose memory layout
# is the STM32F407's, for the figures only a run gives.
#   usage: firmware/budgets.sh
set -uo pipefail
cd "$(dirname "$0")"
target_dir=${CARGO_TARGET_DIR:-$PWD/target}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Section sizes of an ELF: static RAM = .data + .bss + .uninit; flash = .vector_table +
# .text + .rodata + .data (its initial values).
sizes() {
  size -A "$1" | awk '
    $1 == ".data" || $1 == ".bss" || $1 == ".uninit" { ram += $2 }
    $1 == ".vector_table" || $1 == ".text" || $1 == ".rodata" || $1 == ".data" { flash += $2 }
    END { printf "%d %d\n", ram, flash }'
}

# The bench's and the controller's logs leave as defmt frames (decoded by defmt-print, as
# in run-qemu-tests.sh, which installs the same pinned version).
DEFMT_PRINT_VERSION=$(sed -nE 's/^DEFMT_PRINT_VERSION=([0-9.]+).*/\1/p' run-qemu-tests.sh)
if ! command -v defmt-print >/dev/null 2>&1; then
  echo "installing defmt-print $DEFMT_PRINT_VERSION (decodes the firmware's defmt log)" >&2
  cargo install defmt-print --locked --version "$DEFMT_PRINT_VERSION" --quiet >&2 || exit 1
fi

echo "building the three boards' controllers (release) ..." >&2
cargo build --release --quiet --workspace --bins 2>&1 >&2 || exit 1
CARGO_TARGET_DIR=$target_dir/nucleo-h743zi cargo build --release --quiet --bin controller \
  -p firmware --no-default-features --features board-nucleo-h743zi >&2 || exit 1
CARGO_TARGET_DIR=$target_dir/stm32f407 cargo build --release --quiet --bin controller \
  -p firmware --no-default-features --features board-stm32f407 >&2 || exit 1
elf_dir=$target_dir/thumbv7em-none-eabihf/release
out_dir=$(dirname "$(ls -t "$elf_dir"/build/firmware-testbench-*/out/recording.rs | head -1)")
map_1km=$(stat -c %s "$out_dir/map_1km.bin")
map_10km=$(stat -c %s "$out_dir/map_10km.bin")

echo "running the bench and the controller under QEMU ..." >&2
./qemu-run.sh "$elf_dir/bench" >"$work/bench.log" 2>&1
QEMU_MAP=map_10km.bin ./qemu-run.sh "$elf_dir/bench" >"$work/bench10.log" 2>&1
FW_CONTROLLER_SCANS=40 cargo build --release --quiet --bin controller >&2 || exit 1
./controller-vs-emulator.sh "$elf_dir/controller" "$work/controller.log"
# Back to the product build (no scan limit): the sizes below are its, and `host-sim hil`
# runs the controller in this target directory.
cargo build --release --quiet --bin controller >&2 || exit 1
hwm=$(sed -nE 's/.*stack high-water mark ([0-9]+) bytes = .*/\1/p' "$work/controller.log" | tail -1)

kib() { awk -v b="$1" 'BEGIN { printf "%.1f KiB", b / 1024 }'; }
echo
echo "## Memory (controller binary; stack high-water mark measured under QEMU with the F407 layout, the same code on every board)"
echo
echo "| board | static RAM | + stack high-water mark | = RAM (budget 96 KiB) | flash for code | + 1 km map image | = flash (F407 budget 512 KiB) | 10 km map image |"
echo "|---|---|---|---|---|---|---|---|"
for board in mps2-an386:$elf_dir stm32f407:$target_dir/stm32f407/thumbv7em-none-eabihf/release \
  nucleo-h743zi:$target_dir/nucleo-h743zi/thumbv7em-none-eabihf/release; do
  name=${board%%:*} dir=${board#*:}
  read -r ram flash < <(sizes "$dir/controller")
  echo "| $name | $(kib "$ram") | $(kib "${hwm:-0}") | $(kib $((ram + ${hwm:-0}))) | $(kib "$flash") | $(kib "$map_1km") | $(kib $((flash + map_1km))) | $(kib "$map_10km") |"
done
echo
echo "## Instructions per scan (QEMU mps2-an386, Cortex-M4F, 1141-beam LMS511 scans; budget 1.5 M end to end)"
echo
echo "| stage | mean | max |"
echo "|---|---|---|"
sed -nE 's/^stage (.*): mean ([0-9]+) max ([0-9]+)$/| \1 | \2 | \3 |/p' "$work/bench.log"
echo
grep -E '^ram:|^budget' "$work/bench.log" | sed 's/^/bench /'
echo "10 km map: $(grep -E '^stage end-to-end \(controller\): ' "$work/bench10.log")"
