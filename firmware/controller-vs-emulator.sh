#!/usr/bin/env bash
# Runs the controller ELF under QEMU mps2-an386 against lidar-driver's LMS5xx emulator (which
# replays the testbench's recorded CoLa-B scans over TCP on UART0) and writes its decoded
# defmt log. No -icount: in icount mode QEMU feeds the UART one byte per main-loop turn, far
# slower than the emulator's 25 Hz, so the per-scan counts logged follow QEMU's clock, not the
# instructions executed (those are the bench's).
#   usage: controller-vs-emulator.sh ELF LOG [QEMU ARGS...]
#   env:   QEMU_TIMEOUT_S (default 300)
# Exit status: QEMU's (the firmware's semihosting exit; 124 on time-out; 2 if the emulator
# did not start).
set -uo pipefail
cd "$(dirname "$0")"
elf=$1 log=$2
shift 2
timeout_s=${QEMU_TIMEOUT_S:-300}
host_target=${CARGO_TARGET_DIR_HOST:-$PWD/../target}
out_dir=$(dirname "$(ls -t "$(dirname "$elf")"/build/firmware-testbench-*/out/recording.rs 2>/dev/null | head -1)")
work=$(mktemp -d)
trap 'kill "${emulator_pid:-}" 2>/dev/null; rm -rf "$work"' EXIT
(cd .. && cargo build --release --quiet -p lms5xx-emulator) || exit 2
"$host_target/release/lms5xx-emulator" --recording "$out_dir/scans_colab.bin" --port 0 \
  --duration-s "$timeout_s" >"$work/emulator.log" 2>&1 &
emulator_pid=$!
port=""
for _ in $(seq 50); do
  port=$(sed -nE 's/.*listening on 127\.0\.0\.1:([0-9]+).*/\1/p' "$work/emulator.log" | head -1)
  [ -n "$port" ] && break
  sleep 0.2
done
if [ -z "$port" ]; then
  echo "LMS5xx emulator did not start: $(cat "$work/emulator.log")" >&2
  exit 2
fi
timeout "$timeout_s" qemu-system-arm -machine mps2-an386 -nographic \
  -semihosting-config enable=on,target=native \
  -serial "tcp:127.0.0.1:$port" \
  -device "loader,file=$out_dir/map.bin,addr=0x00300000" \
  -device "loader,file=$out_dir/config.bin,addr=0x003FE000" \
  -device "loader,file=$out_dir/start_pose.bin,addr=0x003FF000" \
  "$@" -kernel "$elf" >"$work/raw.defmt"
status=$?
defmt-print -e "$elf" <"$work/raw.defmt" >"$log"
exit "$status"
