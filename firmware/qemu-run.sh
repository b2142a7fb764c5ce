#!/usr/bin/env bash
# Runs a firmware ELF under QEMU mps2-an386 with the instruction-counting clock and prints
# its decoded defmt log: the cargo runner (.cargo/config.toml) and the runner of
# run-qemu-tests.sh. Exit status is the firmware's (semihosting exit: 0 success, 1 failure),
# 124 on time-out.
#   usage: qemu-run.sh ELF [QEMU ARGS...]
#   env:   QEMU_TIMEOUT_S (default 300), QEMU_SERIAL (UART0, default null),
#          QEMU_ODOMETRY (the bytes UART1, the vehicle port, receives; default the
#          recording's odometry_frames.bin: one odometry frame per scan),
#          QEMU_VEHICLE_OUT (where UART1's output, the pose frames, goes; default discarded),
#          QEMU_MAP (the map image file flashed, default the recording's map.bin; the
#          testbench also writes map_1km.bin and map_10km.bin, the same tunnel longer)
# The testbench's recorded map image, configuration record and start pose go into the map
# flash region (the map at 0x00300000, the configuration in the 4 KiB before the last at
# 0x003FE000, the start pose in its last 4 KiB at 0x003FF000), as a flasher would put them
# (the selftest checks them; the controller uses them).
set -uo pipefail
elf=$1
shift
out_dir=$(dirname "$(ls -t "$(dirname "$elf")"/build/firmware-testbench-*/out/recording.rs 2>/dev/null | head -1)" 2>/dev/null)
[ "$out_dir" = "." ] && out_dir=""
loader=()
[ -n "$out_dir" ] && loader=(-device "loader,file=$out_dir/${QEMU_MAP:-map.bin},addr=0x00300000"
  -device "loader,file=$out_dir/config.bin,addr=0x003FE000"
  -device "loader,file=$out_dir/start_pose.bin,addr=0x003FF000")
raw=$(mktemp)
fifo_dir=$(mktemp -d)
trap 'rm -f "$raw"; rm -rf "$fifo_dir"; kill $(jobs -p) 2>/dev/null' EXIT
# UART1 (the odometry port) reads the recorded odometry frames, through a pipe chardev
# (QEMU 7's file chardev cannot take input): QEMU reads $fifo_dir/odometry.in.
odometry=${QEMU_ODOMETRY:-${out_dir:+$out_dir/odometry_frames.bin}}
uart1=(-serial null)
if [ -n "$odometry" ] && [ -f "$odometry" ]; then
  mkfifo "$fifo_dir/odometry.in" "$fifo_dir/odometry.out"
  cat "$odometry" >"$fifo_dir/odometry.in" &
  cat "$fifo_dir/odometry.out" >"${QEMU_VEHICLE_OUT:-/dev/null}" &
  vehicle_reader=$!
  uart1=(-chardev "pipe,id=odometry,path=$fifo_dir/odometry" -serial chardev:odometry)
fi
timeout "${QEMU_TIMEOUT_S:-300}" qemu-system-arm \
  -machine mps2-an386 -nographic \
  -semihosting-config enable=on,target=native \
  -icount shift=0 \
  -serial "${QEMU_SERIAL:-null}" "${uart1[@]}" \
  "${loader[@]}" "$@" \
  -kernel "$elf" >"$raw"
status=$?
# QEMU has closed the vehicle port: let its reader write the last bytes.
[ -n "${vehicle_reader:-}" ] && wait "$vehicle_reader"
defmt-print -e "$elf" <"$raw" || [ "$status" -ne 0 ] || status=1
exit "$status"
