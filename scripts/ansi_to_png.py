#!/usr/bin/env python3
"""Turns a terminal capture of examples/walk (tmux capture-pane -p -e) into a PNG: every upper-half-
block cell is two pixels, foreground above background, as the terminal shows them. Other lines
(the status line) are skipped. Usage: ansi_to_png.py CAPTURE.txt OUT.png [SCALE]"""
import re
import struct
import sys
import zlib


def cells(line):
    fg, bg, out = (0, 0, 0), (0, 0, 0), []
    for m in re.finditer(r"\x1b\[([0-9;]*)m|(.)", line):
        if m.group(1) is not None:
            p = [int(x) for x in m.group(1).split(";") if x]
            i = 0
            while i < len(p):
                if p[i] in (38, 48) and i + 4 < len(p) and p[i + 1] == 2:
                    c = tuple(p[i + 2:i + 5])
                    fg, bg = (c, bg) if p[i] == 38 else (fg, c)
                    i += 5
                else:
                    if p[i] == 0:
                        fg, bg = (0, 0, 0), (0, 0, 0)
                    i += 1
        elif m.group(2) == "\u2580":
            out.append((fg, bg))
    return out


def write_png(path, rows):
    h, w = len(rows), len(rows[0])
    raw = b"".join(b"\0" + bytes(v for px in row for v in px) for row in rows)
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def main():
    text = open(sys.argv[1], encoding="utf-8", errors="replace").read().split("\n")
    scale = int(sys.argv[3]) if len(sys.argv) > 3 else 4
    grid = [c for c in (cells(line) for line in text) if c]
    width = min(len(c) for c in grid)
    rows = []
    for c in grid:
        for half in (0, 1):
            row = [px for cell in c[:width] for px in [cell[half]] * scale]
            rows.extend([row] * scale)
    write_png(sys.argv[2], rows)


if __name__ == "__main__":
    main()
