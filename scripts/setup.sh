#!/usr/bin/env bash
# Installs what the tests need beyond cargo: the Cortex-M target (via rust-toolchain.toml),
# QEMU for the firmware runs and socat for the serial loopback tests. Idempotent; safe to
# run on every test run. Needs root (or sudo) for apt-get on a fresh machine.
set -euo pipefail
cd "$(dirname "$0")/.."

# rust-toolchain.toml lists the target; `rustup show` installs what is missing.
rustup show >/dev/null 2>&1 || true
rustup target list --installed 2>/dev/null | grep -q thumbv7em-none-eabihf \
  || rustup target add thumbv7em-none-eabihf

need=()
command -v qemu-system-arm >/dev/null 2>&1 || need+=(qemu-system-arm)
command -v socat >/dev/null 2>&1 || need+=(socat)
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  echo "setup: installing ${need[*]} from Debian's packages"
  $SUDO apt-get update -qq
  extra=()
  # On machines with qemu-utils 10 from backports, qemu-system-arm (bookworm) needs the
  # matching qemu-utils, hence the allowed downgrade.
  if dpkg -s qemu-utils >/dev/null 2>&1 && dpkg -s qemu-utils | grep -q '^Version: 1:10'; then
    extra+=(--allow-downgrades qemu-utils/bookworm)
  fi
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
    "${need[@]}" "${extra[@]}" >/dev/null
fi
echo "setup: toolchain target, qemu-system-arm and socat present"
