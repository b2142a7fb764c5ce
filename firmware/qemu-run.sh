#!/usr/bin/env bash
# Cargo runner (.cargo/config.toml): runs a firmware ELF under QEMU mps2-an386 with the
# instruction-counting clock and decodes its defmt output. Exit status is the firmware's
# (semihosting exit: 0 success, 1 failure); 124 on timeout.
#   usage: qemu-run.sh ELF   (env: QEMU_TIMEOUT_S, default 120; QEMU_SERIAL, default null)
set -euo pipefail
elf=$1
timeout "${QEMU_TIMEOUT_S:-300}" qemu-system-arm \
  -machine mps2-an386 -nographic \
  -semihosting-config enable=on,target=native \
  -icount shift=0 \
  -serial "${QEMU_SERIAL:-null}" \
  -kernel "$elf" \
  | defmt-print -e "$elf"
