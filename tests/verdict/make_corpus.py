#!/usr/bin/env python3
"""Rebuilds the micro/macro corpus of tests/verdict/ from Debian 12 packages.

  tests/verdict/make_corpus.py crops   [TEXTOND]   # download, extract, crop into corpus/
  tests/verdict/make_corpus.py sheets  [TEXTOND]   # contact sheets: exemplar | ADSN, label

corpus.tsv names each texture's package, version, path (ARCHIVE:MEMBER inside a pk3) and
licence, and its label (LABELLING.md says how labels were given) and half of the split. A crop is
the source scaled (box filter) so that its short side is 256, then its centred 256 x 256, saved
as JPEG quality 92; the verdict is computed on these crops. Needs apt-get, dpkg-deb, unzip and
oiiotool (openimageio-tools); downloads about 1 GB into build/verdict/.
"""
import concurrent.futures as cf
import csv
import glob
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
WORK = os.path.join(ROOT, "build", "verdict")
FONT = "/usr/share/fonts/truetype/dejavu/DejaVuSansMono.ttf"


def rows():
    with open(os.path.join(HERE, "corpus.tsv")) as f:
        return list(csv.DictReader(f, delimiter="\t"))


def source_file(row):
    """The source image on disk, extracting its package (and pk3) on first use."""
    pkg_dir = os.path.join(WORK, row["package"])
    if not os.path.isdir(pkg_dir):
        os.makedirs(WORK, exist_ok=True)
        subprocess.run(["apt-get", "download", f"{row['package']}={row['version']}"], cwd=WORK,
                       check=True)
        deb = glob.glob(os.path.join(WORK, f"{row['package']}_*.deb"))[0]
        subprocess.run(["dpkg-deb", "-x", deb, pkg_dir], check=True)
    archive, _, member = row["path"].partition(":")
    if not member:
        return os.path.join(pkg_dir, archive.lstrip("/"))
    out = os.path.join(pkg_dir, "pk3")
    if not os.path.exists(os.path.join(out, member)):
        subprocess.run(["unzip", "-q", "-o", os.path.join(pkg_dir, archive.lstrip("/")), member,
                        "-d", out], check=True)
    return os.path.join(out, member)


def crop(row):
    src = source_file(row)
    w, h = (int(v) for v in row["source_size"].split("x"))
    info = subprocess.run(["oiiotool", "--info", src], capture_output=True, text=True).stdout
    ch = "R,G,B" if (", 3 channel" in info or ", 4 channel" in info) else "0"
    short = min(w, h)
    nw, nh = w * 256 // short, h * 256 // short
    args = ["oiiotool", src, "--ch", ch]
    if short != 256:
        args += ["--resize:filter=box", f"{nw}x{nh}"]
    args += ["--cut", f"256x256+{(nw - 256) // 2}+{(nh - 256) // 2}", "--quality", "92", "-o",
             os.path.join(HERE, "corpus", row["name"] + ".jpg")]
    subprocess.run(args, check=True, capture_output=True)


def pair(row, textond):
    """exemplar | ADSN synthesis (160 px each) over a caption with the label and the name."""
    ex = os.path.join(HERE, "corpus", row["name"] + ".jpg")
    syn = os.path.join(WORK, "sheets", row["name"] + ".adsn.png")
    out = os.path.join(WORK, "sheets", row["name"] + ".pair.png")
    subprocess.run([textond, "synth", ex, "--method", "adsn", "--width", "256", "--height", "256",
                    "--seed", "1", "-o", syn], check=True, capture_output=True)
    rgb = []
    for p in (ex, syn):
        info = subprocess.run(["oiiotool", "--info", p], capture_output=True, text=True).stdout
        rgb.append("R,G,B" if ", 3 channel" in info else "0,0,0")
    caption = f"{row['label']:10} {row['name']}"
    subprocess.run(["oiiotool", ex, "--ch", rgb[0], "--resize", "160x160", syn, "--ch", rgb[1],
                    "--resize", "160x160", "--mosaic:pad=2", "2x1", "--crop", "322x182+0+0",
                    "--fullpixels", f"--text:x=4:y=177:size=14:color=1,1,1:font={FONT}", caption,
                    "-o", out], check=True, capture_output=True)
    return out


def sheets(textond):
    os.makedirs(os.path.join(WORK, "sheets"), exist_ok=True)
    rs = rows()
    with cf.ThreadPoolExecutor(os.cpu_count()) as ex:
        pairs = list(ex.map(lambda r: pair(r, textond), rs))
    for s in range(0, len(pairs), 24):
        part = pairs[s:s + 24]
        out = os.path.join(HERE, f"contact_sheet_{s // 24 + 1}.jpg")
        subprocess.run(["oiiotool", *part, "--mosaic:pad=8", f"4x{(len(part) + 3) // 4}",
                        "--quality", "85", "-o", out], check=True)
        print(out)


def main():
    what = sys.argv[1] if len(sys.argv) > 1 else "sheets"
    textond = sys.argv[2] if len(sys.argv) > 2 else os.path.join(ROOT, "build/release/textond")
    if what == "crops":
        os.makedirs(os.path.join(HERE, "corpus"), exist_ok=True)
        for r in rows():
            crop(r)
    sheets(textond)


if __name__ == "__main__":
    main()
