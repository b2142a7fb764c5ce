#!/usr/bin/env bash
# Cargo runner (.cargo/config.toml): runs a firmware ELF under QEMU mps2-an386 with the
# instruction-counting clock and decodes its defmt output. Exit status is the firmware's
# (semihosting exit: 0 success, 1 failure); 124 on timeout.
#   usage: qemu-run.sh ELF   (env: QEMU_TIMEOUT_S, default 300; QEMU_SERIAL, default null)
set -euo pipefail
elf=$1
# The recorded map of this build goes into the map flash region (0x00300000), as a flasher
# would put it (the selftest checks it; the controller uses it).
map_file=$(ls -t "$(dirname "$elf")"/build/firmware-*/out/map.bin 2>/dev/null | head -1 || true)
loader=()
[ -n "$map_file" ] && loader=(-device "loader,file=$map_file,addr=0x00300000")
timeout "${QEMU_TIMEOUT_S:-300}" qemu-system-arm \
  -machine mps2-an386 -nographic \
  -semihosting-config enable=on,target=native \
  -icount shift=0 \
  -serial "${QEMU_SERIAL:-null}" \
  "${loader[@]}" \
  -kernel "$elf" \
  | defmt-print -e "$elf"
