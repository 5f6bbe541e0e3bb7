#!/usr/bin/env python3
"""Rebuilds a micro/macro corpus of tests/verdict/ from Debian 12 packages.

  tests/verdict/make_corpus.py crops   [--corpus DIR] [TEXTOND]  # download, extract, crop
  tests/verdict/make_corpus.py sheets  [--corpus DIR] [TEXTOND]  # exemplar | ADSN, label
  tests/verdict/make_corpus.py draw    [--corpus DIR]            # the seeded candidate draws
  tests/verdict/make_corpus.py tints   [--corpus DIR] [--against DIR]  # pairs: one a tint
  tests/verdict/make_corpus.py native  [--corpus DIR]            # sources as the service sees them

DIR is tests/verdict (the first corpus), tests/verdict/shapes, third, fourth, fifth or sixth; its
corpus.tsv names each texture's package, version, path (ARCHIVE:MEMBER inside a pk3) and
licence, and its label (DIR/LABELLING.md says how labels were given) and half of the split. A crop is the source
scaled (box filter) so that its short side is 256, then its centred 256 x 256, saved as JPEG
quality 92; the verdict is computed on these crops. `draw` prints the candidates a corpus was
picked from (DIR/draws.json: packages, seeds, keyword filter, and "after": corpora whose
candidates are never drawn again), one TSV row each, with the licence its package's
debian/copyright gives the file. `tints` prints every pair of the corpus's crops whose 48 x 48
grey levels correlate above 0.9, the rule by which the fourth, fifth and sixth corpora dropped
the same image in another tint (none are left in any), and with --against the pairs with
another corpus's crops (none between the fifth and the fourth, nor the sixth and any earlier). `native` writes each source as the
service analyses it (its centred 1024 x 1024 window when larger, core/working_window.h) to
build/verdict/native/NAME_OF_DIR/corpus/NAME.png with a corpus.tsv, for the verdict's two
scales (build/release/tests/verdict_scales, fit_verdict.py --scales). Needs apt-get, dpkg-deb, unzip and
oiiotool (openimageio-tools); downloads 1-2 GB into build/verdict/.
"""
import argparse
import concurrent.futures as cf
import csv
import fnmatch
import glob
import hashlib
import json
import math
import os
import random
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import threading
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "tests", "support"))
from fft_sizes import fast_side  # noqa: E402
WORK = os.path.join(ROOT, "build", "verdict")
FONT = "/usr/share/fonts/truetype/dejavu/DejaVuSansMono.ttf"
UNZIP = threading.Lock()


def rows(corpus):
    with open(os.path.join(corpus, "corpus.tsv")) as f:
        return list(csv.DictReader(f, delimiter="\t"))


def package_dir(package, version=None):
    """The package's files under build/verdict/PACKAGE, downloading it on first use. Extracted
    beside and renamed, so that an interrupted run leaves no half of a package behind; callers
    that run in parallel fetch each package first (fetch_packages)."""
    pkg_dir = os.path.join(WORK, package)
    if not os.path.isdir(pkg_dir):
        os.makedirs(WORK, exist_ok=True)
        spec = f"{package}={version}" if version else package
        subprocess.run(["apt-get", "download", spec], cwd=WORK, check=True)
        deb = glob.glob(os.path.join(WORK, f"{package}_*.deb"))[0]
        tmp = tempfile.mkdtemp(dir=WORK)
        try:
            subprocess.run(["dpkg-deb", "-x", deb, tmp], check=True)
            os.rename(tmp, pkg_dir)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    return pkg_dir


def fetch_packages(rs):
    for package, version in sorted({(r["package"], r["version"]) for r in rs}):
        package_dir(package, version)


def source_file(row):
    """The source image on disk, extracting its package (and pk3) on first use."""
    pkg_dir = package_dir(row["package"], row["version"])
    archive, _, member = row["path"].partition(":")
    if not member:
        return os.path.join(pkg_dir, archive.lstrip("/"))
    out = os.path.join(pkg_dir, "pk3")
    with UNZIP:  # two unzips creating one folder at once fail
        if not os.path.exists(os.path.join(out, member)):
            subprocess.run(["unzip", "-q", "-o", os.path.join(pkg_dir, archive.lstrip("/")), member,
                            "-d", out], check=True)
    return os.path.join(out, member)


def is_colour(path):
    """Whether the image has colour channels (3, or 4 with alpha), by oiiotool --info."""
    info = subprocess.run(["oiiotool", "--info", path], capture_output=True, text=True).stdout
    return ", 3 channel" in info or ", 4 channel" in info


def crop(row, corpus):
    src = source_file(row)
    w, h = (int(v) for v in row["source_size"].split("x"))
    ch = "R,G,B" if is_colour(src) else "0"
    short = min(w, h)
    nw, nh = w * 256 // short, h * 256 // short
    args = ["oiiotool", src, "--ch", ch]
    if short != 256:
        args += ["--resize:filter=box", f"{nw}x{nh}"]
    args += ["--cut", f"256x256+{(nw - 256) // 2}+{(nh - 256) // 2}", "--quality", "92", "-o",
             os.path.join(corpus, "corpus", row["name"] + ".jpg")]
    subprocess.run(args, check=True, capture_output=True)


def native(row, out):
    """The source as the service analyses it (core::window_size at r 64): its centred window of
    at most 1024 pixels a side, each side cut to a fast FFT size."""
    src = source_file(row)
    w, h = (int(v) for v in row["source_size"].split("x"))
    ch = "R,G,B" if is_colour(src) else "0"
    args = ["oiiotool", src, "--ch", ch]
    cw, chh = fast_side(min(w, 1024), 128), fast_side(min(h, 1024), 128)
    if (cw, chh) != (w, h):
        args += ["--cut", f"{cw}x{chh}+{(w - cw) // 2}+{(h - chh) // 2}"]
    # Metadata off: libpng refuses some JPEGs' colour profiles.
    args += ["--eraseattrib", ".*", "-d", "uint8", "-o",
             os.path.join(out, "corpus", row["name"] + ".png")]
    subprocess.run(args, check=True, capture_output=True)


def pair(row, corpus, textond):
    """exemplar | ADSN synthesis (160 px each) over a caption with the label and the name."""
    ex = os.path.join(corpus, "corpus", row["name"] + ".jpg")
    sheets_dir = os.path.join(WORK, "sheets", os.path.basename(corpus))
    syn = os.path.join(sheets_dir, row["name"] + ".adsn.png")
    out = os.path.join(sheets_dir, row["name"] + ".pair.png")
    subprocess.run([textond, "synth", ex, "--method", "adsn", "--width", "256", "--height", "256",
                    "--seed", "1", "-o", syn], check=True, capture_output=True)
    rgb = []
    for p in (ex, syn):
        rgb.append("R,G,B" if is_colour(p) else "0,0,0")
    caption = f"{row['label'] or '?':10} {row['name']}"
    subprocess.run(["oiiotool", ex, "--ch", rgb[0], "--resize", "160x160", syn, "--ch", rgb[1],
                    "--resize", "160x160", "--mosaic:pad=2", "2x1", "--crop", "322x182+0+0",
                    "--fullpixels", f"--text:x=4:y=177:size=14:color=1,1,1:font={FONT}", caption,
                    "-o", out], check=True, capture_output=True)
    return out


def sheets(corpus, textond):
    os.makedirs(os.path.join(WORK, "sheets", os.path.basename(corpus)), exist_ok=True)
    rs = rows(corpus)
    with cf.ThreadPoolExecutor(os.cpu_count()) as ex:
        pairs = list(ex.map(lambda r: pair(r, corpus, textond), rs))
    for s in range(0, len(pairs), 24):
        part = pairs[s:s + 24]
        out = os.path.join(corpus, f"contact_sheet_{s // 24 + 1}.jpg")
        subprocess.run(["oiiotool", *part, "--mosaic:pad=8", f"4x{(len(part) + 3) // 4}",
                        "--quality", "85", "-o", out], check=True)
        print(out)


def stream_size(f):
    """(width, height) of the PNG, JPEG or DDS an open binary file holds, or None."""
    head = f.read(32)
    if head[:8] == b"\x89PNG\r\n\x1a\n":
        return struct.unpack(">II", head[16:24])
    if head[:4] == b"DDS ":
        h, w = struct.unpack("<II", head[12:20])
        return w, h
    if head[:2] != b"\xff\xd8":
        return None
    f.seek(2)
    while True:
        b = f.read(1)
        while b and b != b"\xff":
            b = f.read(1)
        while b == b"\xff":
            b = f.read(1)
        if not b:
            return None
        marker = b[0]
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
            continue
        length = struct.unpack(">H", f.read(2))[0]
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            h, w = struct.unpack(">HH", f.read(5)[1:5])
            return w, h
        f.seek(length - 2, 1)


def copyright_stanzas(pkg_dir, package):
    """(file patterns, licence) of the package's machine-readable debian/copyright, in order."""
    path = os.path.join(pkg_dir, "usr/share/doc", package, "copyright")
    stanzas, files, field, first = [], None, None, None
    for line in open(path, encoding="utf-8", errors="replace"):
        if line.startswith("License:") and first is None:
            first = line[8:].strip()
        if line.startswith("Files:"):
            files, field = line[6:].split(), "files"
        elif line.startswith("License:") and files is not None:
            stanzas.append((files, line[8:].strip()))
            files, field = None, None
        elif line[:1] in (" ", "\t") and field == "files" and files is not None:
            files += line.split()
        elif line.strip():
            field = None
    # A copyright file that is not machine-readable: its first licence covers every file.
    return stanzas or ([(["*"], first)] if first else [])


def licence_of(stanzas, install_path):
    """DEP-5: the last stanza whose pattern matches wins; installed paths are matched by the
    pattern's tail (data/textures/x.png matches /usr/share/games/supertuxkart/data/...)."""
    found = None
    for patterns, licence in stanzas:
        for p in patterns:
            if p == "*" or fnmatch.fnmatch(install_path, "*/" + p.lstrip("/")):
                found = licence
    return found or "see debian/copyright"


def draw(corpus):
    """The candidates of each seeded draw in DIR/draws.json, one TSV row each."""
    print("draw\tpackage\tversion\tpath\tlicence\tsource_size")
    for row in candidates(corpus):
        print("\t".join(row))


def candidates(corpus):
    """(draw, package, version, path, licence, WxH) of each file the seeded draws pick. A file
    an earlier corpus's draws picked (draws.json "after": their directories) is never picked
    again, kept there or not."""
    spec = json.load(open(os.path.join(corpus, "draws.json")))
    taken = set()
    for earlier in spec.get("after", []):
        taken |= {(r[1], r[3]) for r in candidates(os.path.join(corpus, earlier))}
    out = []
    for d in spec["draws"]:
        for package in d["packages"]:
            version = spec["versions"][package]
            pkg_dir = package_dir(package, version)
            stanzas = copyright_stanzas(pkg_dir, package)
            keyword = re.compile(d["keyword"]) if d.get("keyword") else None
            skip = re.compile(d["skip"]) if d.get("skip") else None
            under = d.get("under", {}).get(package, "")
            skip_dirs = re.compile(d["skip_dirs"], re.I) if d.get("skip_dirs") else None
            files, seen = [], set()

            def consider(rel, name, opener):
                low = name.lower()
                if not low.endswith((".png", ".jpg", ".jpeg", ".dds")):
                    return
                if keyword and not keyword.search(low) or skip and skip.search(low):
                    return
                if under not in rel or skip_dirs and skip_dirs.search(rel):
                    return
                with opener() as f:
                    size = stream_size(f)
                if not size or min(size) < 256:
                    return
                # A file seen before, under any name, or drawn by an earlier draw is skipped.
                with opener() as f:
                    digest = hashlib.sha256(f.read()).hexdigest()
                if digest in seen or (package, rel) in taken:
                    seen.add(digest)
                    return
                seen.add(digest)
                files.append((rel, size))

            # Members of a zip archive (a jar, a game's data.zip) are named ARCHIVE:MEMBER.
            archive = d.get("archives", {}).get(package)
            if archive:
                with zipfile.ZipFile(os.path.join(pkg_dir, archive.lstrip("/"))) as z:
                    for m in sorted(z.namelist()):
                        consider(f"{archive}:{m}", os.path.basename(m),
                                 lambda m=m: z.open(m))
            else:
                for dirpath, dirs, names in os.walk(pkg_dir):
                    dirs.sort()
                    for n in sorted(names):
                        full = os.path.join(dirpath, n)
                        consider(full[len(pkg_dir):], n, lambda full=full: open(full, "rb"))
            files.sort()
            pick = sorted(random.Random(d["seed"]).sample(files, min(d["per_package"],
                                                                     len(files))))
            for rel, (w, h) in pick:
                taken.add((package, rel))
                licence = licence_of(stanzas, rel.partition(":")[0])
                out.append((d["name"], package, version, rel, licence, f"{w}x{h}"))
    return out


def grey48(path):
    """The crop's grey level at 48 x 48, centred and scaled to unit variance."""
    with tempfile.TemporaryDirectory() as tmp:
        pgm = os.path.join(tmp, "grey.pgm")
        subprocess.run(["oiiotool", path, "--ch", "0", "--resize", "48x48", "-d", "uint8", "-o",
                        pgm], capture_output=True, check=True)
        with open(pgm, "rb") as f:
            px = list(f.read().split(b"\n", 3)[3])
    mean = sum(px) / len(px)
    sd = math.sqrt(sum((v - mean) ** 2 for v in px) / len(px)) or 1.0
    return [(v - mean) / sd for v in px]


def tints(corpus, against=()):
    """Pairs of crops above 0.9 within the corpus, and with each corpus in `against`."""
    def greys(d):
        names = [r["name"] for r in rows(d)]
        with cf.ThreadPoolExecutor(os.cpu_count()) as ex:
            return dict(zip(names, ex.map(
                lambda n: grey48(os.path.join(d, "corpus", n + ".jpg")), names)))
    grey = greys(corpus)
    names = list(grey)
    pairs = [(a, b, grey[b]) for i, a in enumerate(names) for b in names[i + 1:]]
    for other in against:
        theirs = greys(other)
        pairs += [(a, os.path.basename(other.rstrip("/")) + "/" + b, v)
                  for a in names for b, v in theirs.items()]
    found = 0
    for a, b, v in pairs:
        c = sum(x * y for x, y in zip(grey[a], v)) / len(v)
        if c > 0.9:
            print(f"{c:.3f}\t{a}\t{b}")
            found += 1
    print(f"{found} pairs above 0.9 ({len(names)} crops, against {len(against)} corpora)")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("what", choices=["crops", "sheets", "draw", "tints", "native"])
    ap.add_argument("textond", nargs="?", default=os.path.join(ROOT, "build/release/textond"))
    ap.add_argument("--corpus", default=HERE)
    ap.add_argument("--against", action="append", default=[],
                    help="tints: another corpus directory to compare with (repeatable)")
    a = ap.parse_args()
    corpus = os.path.abspath(a.corpus)
    if a.what == "draw":
        draw(corpus)
        return
    if a.what == "tints":
        tints(corpus, [os.path.abspath(d) for d in a.against])
        return
    if a.what == "native":
        out = os.path.join(WORK, "native", os.path.basename(corpus))
        os.makedirs(os.path.join(out, "corpus"), exist_ok=True)
        rs = rows(corpus)
        fetch_packages(rs)
        with cf.ThreadPoolExecutor(os.cpu_count()) as ex:
            list(ex.map(lambda r: native(r, out), rs))
        with open(os.path.join(out, "corpus.tsv"), "w") as f:
            f.write("name\tlabel\thalf\n")
            f.writelines(f"{r['name']}\t{r['label']}\t{r['half']}\n" for r in rs)
        return
    if a.what == "crops":
        os.makedirs(os.path.join(corpus, "corpus"), exist_ok=True)
        fetch_packages(rows(corpus))
        with cf.ThreadPoolExecutor(os.cpu_count()) as ex:
            list(ex.map(lambda r: crop(r, corpus), rows(corpus)))
    sheets(corpus, a.textond)


if __name__ == "__main__":
    main()
