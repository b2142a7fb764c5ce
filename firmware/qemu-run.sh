#!/usr/bin/env bash
# Cargo runner (.cargo/config.toml): runs a firmware ELF under QEMU mps2-an386 with the
# instruction-counting clock and decodes its defmt output. Exit status is the firmware's
# (semihosting exit: 0 success, 1 failure); 124 on timeout.
#   usage: qemu-run.sh ELF   (env: QEMU_TIMEOUT_S, default 300; QEMU_SERIAL, default null)
set -euo pipefail
elf=$1
# The testbench's recorded map and start pose go into the map flash region (the map at
# 0x00300000, the start pose in its last 4 KiB at 0x003FF000), as a flasher would put them
# (the selftest checks them; the controller uses them).
out_dir=$(ls -td "$(dirname "$elf")"/build/firmware-testbench-*/out 2>/dev/null | head -1 || true)
loader=()
[ -n "$out_dir" ] && loader=(-device "loader,file=$out_dir/map.bin,addr=0x00300000"
  -device "loader,file=$out_dir/start_pose.bin,addr=0x003FF000")
timeout "${QEMU_TIMEOUT_S:-300}" qemu-system-arm \
  -machine mps2-an386 -nographic \
  -semihosting-config enable=on,target=native \
  -icount shift=0 \
  -serial "${QEMU_SERIAL:-null}" \
  "${loader[@]}" \
  -kernel "$elf" \
  | defmt-print -e "$elf"
