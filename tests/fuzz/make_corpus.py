#!/usr/bin/python3
"""Seed corpus for decode_analyze_fuzzer: the shared exemplars in every accepted format and bit
depth (made with Debian's oiiotool), then broken variants of each: truncated, bit-flipped, with
huge declared sizes (PNG IHDR with a valid CRC, BMP and TIFF headers), and odd channel counts.

usage: make_corpus.py EXEMPLAR_DIR OUT_DIR
"""
import os
import random
import struct
import subprocess
import sys
import tempfile
import zlib

src, out = sys.argv[1:3]
os.makedirs(out, exist_ok=True)
rng = random.Random(1234)
tmp = tempfile.mkdtemp(prefix="textond-corpus-")


def oiio(args, dst):
    r = subprocess.run(["oiiotool", *args, "-o", dst], capture_output=True)
    return r.returncode == 0 and os.path.exists(dst)


def add(name, data):
    with open(os.path.join(out, name), "wb") as f:
        f.write(data)


seeds = []
for name in sorted(os.listdir(src)):
    if not name.endswith(".png"):
        continue
    path = os.path.join(src, name)
    stem = name[:-4]
    small = os.path.join(tmp, stem + "-small.png")
    # Small images keep each run fast; the decoders see the same structures.
    if not oiio([path, "--resize", "96x96"], small):
        continue
    variants = {
        "png8": (["-d", "uint8"], ".png"), "png16": (["-d", "uint16"], ".png"),
        "grey": (["--ch", "R", "-d", "uint8"], ".png"),
        "greyalpha": (["--ch", "R,G", "--chnames", "Y,A", "-d", "uint16"], ".png"),
        "rgba16": (["--ch", "R,G,B,=1", "-d", "uint16"], ".png"),
        "jpeg": (["-d", "uint8"], ".jpg"), "tiff8": (["-d", "uint8"], ".tif"),
        "tifffloat": (["-d", "float"], ".tif"), "exrhalf": (["-d", "half"], ".exr"),
        "exrfloat": (["-d", "float"], ".exr"), "bmp": (["-d", "uint8"], ".bmp"),
    }
    for tag, (args, ext) in variants.items():
        dst = os.path.join(tmp, f"{stem}-{tag}{ext}")
        if oiio([small, *args], dst):
            seeds.append((f"{stem}-{tag}", open(dst, "rb").read()))

for name, data in seeds:
    add(name, data)
    add(name + "-trunc", data[: max(8, len(data) // 3)])
    flipped = bytearray(data)
    for _ in range(8):
        i = rng.randrange(len(flipped))
        flipped[i] ^= 1 << rng.randrange(8)
    add(name + "-flip", bytes(flipped))
    if data[:8] == b"\x89PNG\r\n\x1a\n":  # huge declared size, valid CRC
        ihdr = bytearray(data[12:29])
        ihdr[4:12] = struct.pack(">II", 100000, 100000)
        add(name + "-huge", data[:12] + bytes(ihdr) + struct.pack(">I", zlib.crc32(bytes(ihdr))) + data[33:])
    if data[:2] == b"BM" and len(data) > 26:
        b = bytearray(data)
        b[18:26] = struct.pack("<ii", 70000, -70000)
        add(name + "-huge", bytes(b))
print(f"{len(os.listdir(out))} corpus files in {out}")
