#!/usr/bin/env python3
"""Mutation check (make mutation): each mutation below is a one-line defect in the code that
matters most. It is applied to the working tree alone, only what it touches is rebuilt, the test
suites that should notice are run, and the file is put back byte for byte. A mutation that no
test notices "survives": the suite has a gap there. Run by tests/mutation/run.sh.

Usage: mutations.py BUILD_DIR [NAME ...]   (no NAME: every mutation)
"""
import hashlib
import os
import re
import signal
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# name, file, the original text (unique in the file), its mutant, the test programs that should
# notice (rebuilt, with the server binary when server_test is one; each program's tests are run
# through CTest).
MUTATIONS = [
    ("hash-seed-high-word", "core/noise_hash.h",
     "0x6a09e667u);\n    h = absorb(h, hi32(seed));",
     "0x6a09e667u);",
     ["render_test"]),
    ("poisson-count", "core/grid_poisson.h",
     "    return lo;\n}",
     "    return lo > 0 ? lo - 1 : 0;\n}",
     ["render_test", "render_stats_test"]),
    ("rme-factor-2", "core/rme.cpp",
     "tt + kk - 2.0 * std::abs(cross)",
     "tt + kk - 1.0 * std::abs(cross)",
     ["core_stats_test"]),
    ("box-filter-offset", "core/noise_levels.cpp",
     "box(x - (st - 1), y - (st - 1))",
     "box(x - st, y - (st - 1))",
     ["render_test", "render_stats_test"]),
    ("etag-without-key", "server/app/image_service.cpp",
     '.update("\\n").update(key);',
     '.update("\\n");',
     ["server_test"]),
    ("verdict-band-3x", "core/shape_verdict.cpp",
     "if (score > kShapeBand) return TextureKind::macro;",
     "if (score > 3 * kShapeBand) return TextureKind::macro;",
     ["core_stats_test", "verdict_corpus_test"]),
    ("gl-one-lane", "render/backend_factory.cpp",
     "while (static_cast<int>(lanes.size()) < gl_lanes(options, gl)) {",
     "while (static_cast<int>(lanes.size()) < 1) {",
     ["server_test"]),
    ("verdict-null-ignored", "core/shape_verdict.cpp",
     "out.excess.*field = out.exemplar.*field - mean;",
     "out.excess.*field = out.exemplar.*field - 0.0 * mean;",
     ["core_stats_test", "verdict_corpus_test"]),
    ("verdict-fine-offset-dropped", "core/shape_verdict.cpp",
     "    fine.score -= kFineScaleOffset;",
     "    fine.score -= 0.0 * kFineScaleOffset;",
     ["core_stats_test"]),
    ("verdict-fine-scale-ignored", "core/shape_verdict.cpp",
     "    if (fine.score > out.score) {",
     "    if (fine.score > out.score + 1e9) {",
     ["core_stats_test"]),
    ("admission-without-mni", "server/app/work_cost.cpp",
     "static_cast<double>(pixels) * mni * taps_of_order(order) * 1.5e-9",
     "static_cast<double>(pixels) * taps_of_order(order) * 1.5e-9",
     ["server_test"]),
    ("mix-cost-ignores-levels", "server/app/work_cost.cpp",
     "return levels * pixels * channels * (iterations + kMixFixedIterations)",
     "return pixels * channels * (iterations + kMixFixedIterations)",
     ["server_test"]),
    ("jpeg-scans-unlimited", "server/io/image_io.cpp",
     "scans > kMaxJpegScans)",
     "scans > 1000 * kMaxJpegScans)",
     ["io_test"]),
    ("atomic-write-ignores-errors", "server/io/atomic_file.cpp",
     "        if (n <= 0) return failure(n == 0 ? ENOSPC : errno);",
     "        if (n <= 0) break;",
     ["io_test", "server_test"]),
    ("checksum-not-compared", "server/io/texton_file.cpp",
     "if (coefficients_sha256(r.texton) != m.coefficients_sha256)",
     "if (false && coefficients_sha256(r.texton) != m.coefficients_sha256)",
     ["io_test", "server_test"]),
    ("id-length-unchecked", "api/requests.cpp",
     "if (s.size() != 64) return false;",
     "if (s.size() < 64) return false;",
     ["api_unit_test", "server_test"]),
    ("gl-seed-high-word", "render/gl/noise_window.cpp",
     "const auto seed_hi = static_cast<std::uint32_t>(seed >> 32);",
     "const auto seed_hi = std::uint32_t{0};",
     ["render_test"]),
    ("limit-model-white-noise", "render/cpu_backend.cpp",
     "kappa[i] = static_cast<float>(lm.kappa[static_cast<std::size_t>(i)]);",
     "kappa[i] = i == 12 ? 1.0f : 0.0f; // sum kappa^2 = 1: the variance is kept",
     ["render_stats_test"]),
    ("hlsl-seed-high-word", "render/hlsl/texton_noise.hlsl",
     "seed.x ^ 0x6a09e667u);\n    h = absorb(h, seed.y);",
     "seed.x ^ 0x6a09e667u);",
     ["render_test"]),
    ("sharpness-cross-term", "core/phase_coherence.cpp",
     "2.0 * a * b * omega(",
     "a * b * omega(",
     ["core_stats_test"]),
    ("marginals-level-0-table", "core/marginals.cpp",
     "const double vk = std::min(level_variance[ui], v0);",
     "const double vk = v0;",
     ["core_unit_test", "render_stats_test"]),
    ("kit-fragment-pixel-shift", "render/glsl/texton_noise.frag",
     "ivec2(gl_FragCoord.xy) + u_offset;",
     "ivec2(gl_FragCoord.xy) + u_offset + ivec2(1, 0);",
     ["render_test"]),
    ("normal-derivative-sign", "render/cpu_backend.cpp",
     "    w0 = 1.0f;  // G[t + 1]",
     "    w0 = -1.0f; // G[t + 1]",
     ["render_stats_test"]),
    ("set-shader-height-table", "render/glsl/material_eval.glsl",
     "float h = u_height < 4 ? t0[u_height] : t1[u_height - 4];",
     "float h = t0[u_height & 3];",
     ["render_test"]),
    ("lit-light-elevation", "render/normal_map.cpp",
     "std::cos(el) * std::sin(az), std::sin(el)};",
     "std::cos(el) * std::sin(az), std::cos(el)};",
     ["server_test"]),
    # tile archives (textond export)
    ("pmtiles-hilbert-unrotated", "server/io/pmtiles.cpp",
     "            std::swap(tx, ty);",
     "",
     ["io_test"]),
    ("mbtiles-row-unflipped", "server/io/mbtiles.cpp",
     "return (std::int64_t{1} << z) - 1 - y;",
     "return y;",
     ["io_test", "cli_test"]),
]

_saved = {}  # path -> original bytes, while a mutation is applied


def restore():
    for path, data in _saved.items():
        with open(path, "wb") as f:
            f.write(data)
        os.utime(path)  # newer than the mutant's objects: the next build recompiles it
    _saved.clear()


def on_signal(signum, _frame):
    restore()
    sys.exit(128 + signum)


def run(cmd, log):
    """Runs `cmd`, its output appended to `log`; returns (exit status, output)."""
    p = subprocess.run(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    with open(log, "ab") as out:
        out.write(("$ " + " ".join(cmd) + "\n").encode() + p.stdout)
    return p.returncode, p.stdout.decode("utf-8", "replace")


def suites_regex(build_dir, programs):
    """CTest names a test Suite.Name (gtest_discover_tests): the programs' suites, listed."""
    suites = set()
    for p in programs:
        out = subprocess.run([os.path.join(build_dir, "tests", p), "--gtest_list_tests"],
                             capture_output=True, text=True, check=True).stdout
        suites |= {line.rstrip(".") for line in out.splitlines()
                   if line and not line.startswith((" ", "Running main"))}
    return "^(" + "|".join(sorted(re.escape(s) for s in suites)) + ")\\."


def build(build_dir, targets, log):
    return run(["cmake", "--build", build_dir, "-j", str(os.cpu_count() or 2), "--target"] +
               targets, log)[0]


def main():
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    build_dir = os.path.abspath(sys.argv[1])
    wanted = set(sys.argv[2:])
    chosen = [m for m in MUTATIONS if not wanted or m[0] in wanted]
    if wanted - {m[0] for m in MUTATIONS}:
        print("unknown mutation: " + ", ".join(sorted(wanted - {m[0] for m in MUTATIONS})),
              file=sys.stderr)
        return 2
    # A stale entry (code moved on) is an error, not a silent pass.
    for name, rel, old, new, _ in chosen:
        text = open(os.path.join(ROOT, rel), encoding="utf-8").read()
        if text.count(old) != 1:
            print(f"{name}: the original text occurs {text.count(old)} times in {rel}; "
                  "update tests/mutation/mutations.py", file=sys.stderr)
            return 2
    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    log = os.path.join(build_dir, "mutation.log")
    open(log, "w").close()
    all_targets = sorted({t for m in chosen for t in m[4]} | {"textond"})
    if build(build_dir, all_targets, log) != 0:
        print(f"the unmutated tree does not build (see {log})", file=sys.stderr)
        return 2

    print(f"{'mutation':<28} {'file':<30} {'result':<8} {'s':>4}  first failing test")
    survivors, invalid = [], []
    for name, rel, old, new, programs in chosen:
        targets = programs + (["textond"] if "server_test" in programs else [])
        path = os.path.join(ROOT, rel)
        original = open(path, "rb").read()
        digest = hashlib.sha256(original).hexdigest()
        start = time.monotonic()
        _saved[path] = original
        with open(path, "wb") as f:
            f.write(original.decode("utf-8").replace(old, new).encode("utf-8"))
        try:
            if build(build_dir, targets, log) != 0:
                result, by = "no-build", ""
                invalid.append(name)
            else:
                rc, out = run(["ctest", "--test-dir", build_dir, "-R",
                               suites_regex(build_dir, programs), "--stop-on-failure", "-j",
                               str(os.cpu_count() or 2)], log)
                failed = re.findall(r"^\s*\d+ - (\S+) \(", out, re.M)
                result = "killed" if rc != 0 else "SURVIVED"
                by = failed[0] if failed else ("" if rc == 0 else "ctest failed")
                if rc == 0:
                    survivors.append(name)
        finally:
            restore()
        assert hashlib.sha256(open(path, "rb").read()).hexdigest() == digest
        print(f"{name:<28} {rel:<30} {result:<8} {time.monotonic() - start:4.0f}  {by}", flush=True)

    build(build_dir, all_targets, log)  # the binaries match the sources again
    print(f"{len(chosen) - len(survivors) - len(invalid)} of {len(chosen)} mutations killed, "
          f"{len(survivors)} survived" + (f", {len(invalid)} did not build" if invalid else ""))
    if survivors:
        print("survivors: " + ", ".join(survivors))
    return 1 if survivors or invalid else 0


if __name__ == "__main__":
    sys.exit(main())
