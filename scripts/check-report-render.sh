#!/usr/bin/env bash
# `host-sim optimize`'s report.html rendered by headless Chromium (Debian's package,
# installed if missing): a small search writes its report, Chromium takes a screenshot of
# the page, and the screenshot must show the figures (their blue data lines and bars come
# only from the SVGs the page embeds) and the tables' text. Run by scripts/test-all.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v chromium >/dev/null 2>&1; then
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  echo "report check: installing chromium from Debian's packages"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends chromium >/dev/null
fi
cargo build --release -q -p host-sim
work=$(pwd)/target/report-check
rm -rf "$work"
target/release/host-sim optimize --model f4 --population 10 --generations 3 --length 3 \
  --seed 2 --validation-seeds 2 --out "$work/search" --quiet >/dev/null
# Chromium's own sandbox needs user namespaces a container may not give; the page is ours.
timeout 120 chromium --headless --no-sandbox --disable-gpu --hide-scrollbars \
  --window-size=1200,4000 --screenshot="$work/report.png" "file://$work/search/report.html" \
  >"$work/chromium.log" 2>&1 || { cat "$work/chromium.log" >&2; exit 1; }
python3 - "$work/report.png" <<'PY'
import struct, sys, zlib

def pixels(path):
    """RGB(A) rows of an 8-bit PNG (the filters of the PNG spec, section 9)."""
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat = 8, b""
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, colour = struct.unpack(">IIBB", body[:10])
            assert depth == 8 and colour in (2, 6), f"PNG depth {depth} colour {colour}"
            bpp = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw, stride, prev, rows = zlib.decompress(idat), w * bpp, bytearray(w * bpp), []
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for x in range(stride):
            a = line[x - bpp] if x >= bpp else 0
            b, c = prev[x], prev[x - bpp] if x >= bpp else 0
            if f == 1: line[x] = (line[x] + a) & 255
            elif f == 2: line[x] = (line[x] + b) & 255
            elif f == 3: line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line)
        prev = line
    return w, h, bpp, rows

w, h, bpp, rows = pixels(sys.argv[1])
blue = dark = 0
for line in rows:
    for x in range(0, len(line), bpp):
        r, g, b = line[x], line[x + 1], line[x + 2]
        # The figures' "best" colour (31, 119, 180) and its blends with white.
        if b > r + 60 and b > g + 20:
            blue += 1
        elif r < 80 and g < 80 and b < 80:
            dark += 1
print(f"report check: {w}x{h} screenshot, {blue} figure pixels, {dark} text pixels")
if blue < 2000:
    sys.exit("report check: the figures did not render in report.html")
if dark < 5000:
    sys.exit("report check: the page's text did not render")
PY
