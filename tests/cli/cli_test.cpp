// End-to-end: run the real `textond` executable as a user would.
#include "server/io/image_io.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <set>
#include <sstream>
#include <sys/wait.h>

using namespace textond;
namespace fs = std::filesystem;

TEST(Cli, HelpForEveryCommand) {
    for (const char* c : {"--help", "analyze --help", "synth --help", "bench --help",
                          "render --help", "bench render --help", "bench tile --help",
                          "serve --help", "mix --help", "sign --help", "export --help"}) {
        const test::RunResult r = test::run(c);
        EXPECT_EQ(r.code, 0) << c;
        EXPECT_NE(r.out.find("usage"), std::string::npos) << c;
    }
}

// The baseline load_test.sh divides by: three positive timings (rows render, encode and their
// sum), and the PNG size of a stored 256x256 RGB tile (196,608 bytes of pixels plus the format's
// framing). How the timings compare is not asserted: on a shared 2-core machine the medians of
// five runs moved by 3x under load (a fresh-clone run failed on it), and speed is the
// benchmarks' business, not the tests'.
TEST(Cli, BenchTilePrintsRenderEncodeAndTheirSum) {
    const test::RunResult r = test::run("bench tile --count 5 --size 32 --exemplar " +
                                        test::exemplar_path("etr_sand01.png"));
    ASSERT_EQ(r.code, 0) << r.err;
    double v[3] = {0, 0, 0};
    const char* rows[3] = {"| render |", "| encode |", "| render + encode |"};
    for (int i = 0; i < 3; ++i) {
        const auto at = r.out.find(rows[i]);
        ASSERT_NE(at, std::string::npos) << r.out;
        v[i] = std::stod(r.out.substr(at + std::strlen(rows[i])));
        EXPECT_GT(v[i], 0) << rows[i];
    }
    const auto bytes = r.out.find(" bytes)");
    ASSERT_NE(bytes, std::string::npos);
    const std::size_t start = r.out.rfind(' ', bytes - 1) + 1;
    const long n = std::stol(r.out.substr(start, bytes - start));
    EXPECT_GT(n, 196608);
    EXPECT_LT(n, 196608 + 4096);
}

TEST(Cli, AnalyzePrintsJsonAndWritesATextonThatSynthReads) {
    const std::string texton = test::temp_path("sand.exr"), v1 = test::temp_path("sand.texton"),
                      png = test::temp_path("dsn.png");
    const test::RunResult r =
        test::run("analyze " + test::exemplar_path("etr_sand01.png") +
                  " --size 32 --iterations 20 --seed 3 -o " + texton + " --export-v1 " + v1);
    ASSERT_EQ(r.code, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j.at("id").get<std::string>().size(), 64u);
    EXPECT_GT(j.at("rme").get<double>(), 0.3);
    EXPECT_EQ(j.at("mean").size(), 3u);
    EXPECT_TRUE(j.at("timings_ms").contains("total"));
    EXPECT_TRUE(fs::exists(v1));

    const test::RunResult s =
        test::run("synth " + texton + " --method dsn --width 96 --height 64 --seed 1 -o " + png);
    ASSERT_EQ(s.code, 0) << s.err;
    auto img = io::decode_image_file(png);
    ASSERT_TRUE(img.ok());
    EXPECT_EQ(img.value().width, 96);
    EXPECT_EQ(img.value().height, 64);
}

std::string file_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Many exemplars in one process: a JSON line each, naming its exemplar, a bad file reported and
// passed over (exit 1), names kept apart, and each texton the bytes of a run on its own.
TEST(Cli, AnalyzeManyWritesEachTextonAndKeepsGoingPastABadFile) {
    const fs::path dir = test::temp_path("batch");
    fs::remove_all(dir);
    fs::create_directories(dir / "in");
    const std::string bad = (dir / "in" / "broken.png").string();
    std::ofstream(bad) << "not an image";
    const std::string sand = test::exemplar_path("etr_sand01.png");
    fs::copy_file(test::exemplar_path("etr_pebbles04.png"), dir / "in" / "etr_sand01.png");
    const std::string list = (dir / "list.txt").string();
    std::ofstream(list) << "# the second half\n\n"
                        << bad << "\n"
                        << (dir / "in" / "etr_sand01.png").string() << "\n";
    const std::string opts = " --size 16 --iterations 5";
    const test::RunResult r = test::run("analyze " + sand + " --from-list " + list + " --jobs 2" +
                                        opts + " -o " + (dir / "out").string() + "/");
    EXPECT_EQ(r.code, 1) << r.err;
    std::vector<nlohmann::json> lines;
    std::istringstream out(r.out);
    for (std::string line; std::getline(out, line);) lines.push_back(nlohmann::json::parse(line));
    ASSERT_EQ(lines.size(), 3u) << r.out;
    // Printed as each is done: in the order given only where the work says so. Each line names
    // its exemplar; the two with one path are told apart by their outputs.
    // Order them as given: sand, the bad file, then the other photo named etr_sand01.
    auto rank = [&](const nlohmann::json& l) {
        return l.at("exemplar").at("path") == bad ? 1 : l.at("exemplar").at("path") == sand ? 0 : 2;
    };
    std::sort(lines.begin(), lines.end(),
              [&](const nlohmann::json& x, const nlohmann::json& y) { return rank(x) < rank(y); });
    EXPECT_EQ(lines[0].at("exemplar").at("path"), sand);
    EXPECT_EQ(lines[1].at("exemplar").at("path"), bad);
    EXPECT_TRUE(lines[1].contains("error")) << lines[1];
    EXPECT_FALSE(lines[1].contains("id"));
    EXPECT_NE(lines[0].at("id"), lines[2].at("id")); // same name, other photo
    EXPECT_EQ(lines[0].at("output"), (dir / "out" / "etr_sand01.exr").string());
    EXPECT_EQ(lines[2].at("output"), (dir / "out" / "etr_sand01-2.exr").string());
    const std::string alone = (dir / "alone.exr").string();
    ASSERT_EQ(test::run("analyze " + sand + opts + " --threads 1 -o " + alone).code, 0);
    EXPECT_EQ(file_bytes(alone), file_bytes(lines[0].at("output").get<std::string>()));
    // An output that is an input would replace the exemplar: refused, the file untouched.
    const std::string made = lines[0].at("output").get<std::string>(), before = file_bytes(made);
    EXPECT_EQ(test::run("analyze " + made + opts + " -o " + (dir / "out").string() + "/").code, 2);
    EXPECT_EQ(file_bytes(made), before);
    EXPECT_EQ(test::run("analyze " + sand + " " + sand + opts).code, 2); // no -o DIR/
    // A list that is a directory, an -o that is a file: usage errors, not empty or failed runs.
    EXPECT_EQ(test::run("analyze " + sand + " --from-list " + dir.string() + opts + " -o " +
                        (dir / "out").string() + "/")
                  .code,
              2);
    EXPECT_EQ(test::run("analyze " + sand + opts + " -o " + list + "/").code, 2);
    EXPECT_EQ(test::run("analyze --from-list " + (dir / "none.txt").string() + opts + " -o " +
                        (dir / "out").string())
                  .code,
              2);
    fs::remove_all(dir);
}

// With --jobs, a file's line is printed when that file is done, not after every
// file given before it: a batch stopped by Ctrl-C has a line for each texton it wrote. A large
// exemplar first, then small ones: their lines come first.
TEST(Cli, AnalyzeManyPrintsEachLineWhenItsFileIsDone) {
    const fs::path dir = test::temp_path("batch-order");
    fs::remove_all(dir);
    fs::create_directories(dir);
    core::Image big(2048, 2048, 1);
    for (int y = 0; y < big.height; ++y)
        for (int x = 0; x < big.width; ++x)
            big.data[static_cast<std::size_t>(y) * big.width + x] =
                static_cast<float>((x * 7 + y * 13 + (x * y) % 17) % 256) / 255.0f;
    const std::string big_path = (dir / "big.png").string();
    ASSERT_TRUE(io::encode_image_file(big, big_path, io::Encoding::png8));
    std::string inputs = big_path;
    for (const char* name : {"etr_sand01.png", "etr_pave02.png", "etr_floor01.png"})
        inputs += " " + test::exemplar_path(name);
    const test::RunResult r =
        test::run("analyze " + inputs + " --jobs 2 --size 16 --iterations 60 -o " +
                  (dir / "out").string() + "/");
    ASSERT_EQ(r.code, 0) << r.err;
    std::vector<std::string> order;
    std::istringstream out(r.out);
    for (std::string line; std::getline(out, line);)
        order.push_back(nlohmann::json::parse(line).at("exemplar").at("path"));
    ASSERT_EQ(order.size(), 4u) << r.out;
    EXPECT_EQ(order.back(), big_path) << "a small file's line waited for the large one";
    fs::remove_all(dir);
}

TEST(Cli, SynthFromAnExemplarAtAnySizeAndFormat) {
    for (const char* method : {"adsn", "rpn"}) {
        const std::string out = test::temp_path(std::string(method) + ".exr");
        const test::RunResult r =
            test::run("synth " + test::exemplar_path("skimage_gravel.png") + " --method " + method +
                      " --width 700 --height 300 -o " + out);
        ASSERT_EQ(r.code, 0) << r.err;
        auto img = io::decode_image_file(out);
        ASSERT_TRUE(img.ok());
        EXPECT_EQ(img.value().width, 700);
        EXPECT_EQ(img.value().channels, 1);
    }
}

TEST(Cli, ErrorsGoToStderrWithNonZeroExit) {
    struct Case {
        std::string args;
        int code;
        std::string says;
    };
    const std::string ex = test::exemplar_path("etr_sand01.png");
    const Case cases[] = {
        {"frobnicate", 2, "unknown command"},
        {"analyze", 2, "needs an EXEMPLAR"},
        {"analyze " + ex + " --size 200", 2, "half the exemplar"},
        {"analyze " + ex + " --size abc", 2, "expects an integer"},
        {"analyze " + ex + " --bogus 1", 2, "unknown option"},
        {"analyze /nonexistent/file.png", 1, "no such file"},
        {"analyze " + ex + " --max-pixels 1000", 1, "over the budget"},
        {"synth " + ex + " --method nope -o x.png", 2, "--method"},
        {"synth " + ex + " --method rpn -o x.gif", 2, ".png or .exr"},
        {"synth " + ex + " --method rpn --width 0 -o x.png", 2, "--width"},
    };
    for (const Case& c : cases) {
        const test::RunResult r = test::run(c.args);
        EXPECT_EQ(r.code, c.code) << c.args << "\n" << r.err;
        EXPECT_TRUE(r.out.empty()) << c.args;
        EXPECT_NE(r.err.find(c.says), std::string::npos) << c.args << "\n" << r.err;
    }
}

TEST(Cli, RenderWritesTheAskedWindowOnEverySoftwareBackend) {
    const std::string texton = test::temp_path("render-sand.exr");
    ASSERT_EQ(
        test::run("analyze " + test::exemplar_path("etr_sand01.png") + " --size 32 -o " + texton)
            .code,
        0);
    for (const char* backend : {"cpu", "osmesa", "auto"}) {
        const std::string out = test::temp_path(std::string("render-") + backend + ".png");
        const test::RunResult r =
            test::run("render " + texton + " --x -1099511627776 --y 77 --w 80 --h 48" +
                      " --lod -1 --seed 9 --backend " + backend + " --png16 -o " + out);
        ASSERT_EQ(r.code, 0) << backend << "\n" << r.err;
        const auto j = nlohmann::json::parse(r.out);
        EXPECT_EQ(j.at("noise").get<std::string>(), "textond-noise/1");
        EXPECT_FALSE(j.at("renderer").get<std::string>().empty());
        auto img = io::decode_image_file(out);
        ASSERT_TRUE(img.ok());
        EXPECT_EQ(img.value().width, 80);
        EXPECT_EQ(img.value().height, 48);
        EXPECT_EQ(img.value().channels, 3);
    }
    // An exemplar as INPUT is analysed first; a level above the switch uses the limit model.
    const std::string out = test::temp_path("render-far.exr");
    const test::RunResult r = test::run("render " + test::exemplar_path("skimage_gravel.png") +
                                        " --size 16 --lod 24 --w 32 --h 32 -o " + out);
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(nlohmann::json::parse(r.out).at("limit_model").get<bool>());

    struct Case {
        std::string args;
        int code;
        std::string says;
    };
    const Case cases[] = {
        {"render " + texton + " --lod 25 -o x.png", 2, "--lod"},
        {"render " + texton + " --mni 0 -o x.png", 2, "--mni"},
        {"render " + texton + " --backend vulkan -o x.png", 2, "unknown backend"},
        {"render " + texton + " --lod 20 --x 4611686018427387903 -o x.png", 2, "plane"},
        {"render " + texton + " --period 4 --lod 20 -o x.png", 2, "tileable"},
        {"render " + texton, 2, "-o"},
    };
    for (const Case& c : cases) {
        const test::RunResult e = test::run(c.args);
        EXPECT_EQ(e.code, c.code) << c.args << "\n" << e.err;
        EXPECT_NE(e.err.find(c.says), std::string::npos) << c.args << "\n" << e.err;
    }
}

// textond mix: the default ramp runs across the window, from U's mean colour to V's.
TEST(Cli, MixWritesTheTransitionAcrossTheWindow) {
    const std::string out = test::temp_path("mix.exr");
    const test::RunResult r =
        test::run("mix " + test::exemplar_path("etr_sand01.png") + " " +
                  test::exemplar_path("etr_pebbles04.png") +
                  " --size 16 --iterations 10 --levels 5 --w 2048 --h 64 -o " + out);
    ASSERT_EQ(r.code, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j.at("rme").size(), 5u);
    auto img = io::decode_image_file(out);
    ASSERT_TRUE(img.ok());
    ASSERT_EQ(img.value().width, 2048);
    auto column_mean = [&](int x0) {
        double s = 0;
        for (int y = 0; y < 64; ++y)
            for (int x = x0; x < x0 + 128; ++x) s += img.value().at(2, x, y);
        return s / (64 * 128);
    };
    // Blue: sand is yellow, the pebbles grey, so the blue mean rises from left to right.
    const test::RunResult su =
        test::run("analyze " + test::exemplar_path("etr_sand01.png") + " --size 16");
    const test::RunResult sv =
        test::run("analyze " + test::exemplar_path("etr_pebbles04.png") + " --size 16");
    const double bu = nlohmann::json::parse(su.out).at("mean")[2];
    const double bv = nlohmann::json::parse(sv.out).at("mean")[2];
    EXPECT_NEAR(column_mean(0), bu + (bv - bu) * 64 / 2048.0, 0.3 * std::fabs(bv - bu));
    EXPECT_NEAR(column_mean(2048 - 128), bv - (bv - bu) * 64 / 2048.0, 0.3 * std::fabs(bv - bu));
    for (const char* bad : {"--levels 1", "--ramp 1,2,3", "--ramp 0,0,0,0,10", "--mask-scale 0"}) {
        const test::RunResult e =
            test::run("mix " + test::exemplar_path("etr_sand01.png") + " " +
                      test::exemplar_path("etr_pebbles04.png") + " " + bad + " -o x.png");
        EXPECT_EQ(e.code, 2) << bad << "\n" << e.err;
    }
    EXPECT_EQ(test::run("mix " + test::exemplar_path("etr_sand01.png") + " -o x.png").code, 2);
}

TEST(Cli, ServeHelpShowsEveryFlagWithItsEnvironmentVariable) {
    const test::RunResult r = test::run("serve --help");
    ASSERT_EQ(r.code, 0);
    for (const char* flag : {"--host", "--port", "--data", "--backend", "--api-key", "--cache-mb",
                             "--max-upload-mb", "--max-pixels", "--formats", "--http-threads",
                             "--read-timeout", "--keep-alive-max", "--log-level"})
        EXPECT_NE(r.out.find(flag), std::string::npos) << flag;
    EXPECT_NE(r.out.find("TEXTOND_CACHE_MB"), std::string::npos);
    EXPECT_NE(r.out.find("[./data]"), std::string::npos);
    EXPECT_NE(r.out.find("[127.0.0.1]"), std::string::npos);
    EXPECT_NE(r.out.find("[8080]"), std::string::npos);
}

// Every flag the help documents is one the parser takes (--web-dir and --listen-backlog were
// documented and refused until the image's chroot build served no page).
TEST(Cli, ServeAcceptsEveryFlagItsHelpDocuments) {
    const test::RunResult help = test::run("serve --help");
    ASSERT_EQ(help.code, 0);
    std::set<std::string> flags;
    std::istringstream lines(help.out);
    for (std::string line; std::getline(lines, line);)
        for (std::size_t at = line.find("--"); at != std::string::npos;
             at = line.find("--", at + 2)) {
            std::size_t end = at + 2;
            while (end < line.size() &&
                   (std::isalnum(static_cast<unsigned char>(line[end])) || line[end] == '-'))
                ++end;
            if (end > at + 2 && (at == 0 || line[at - 1] == ' '))
                flags.insert(line.substr(at, end - at));
        }
    EXPECT_GE(flags.size(), 25u);
    // A value flag without its value says so; a switch goes on to serve, so give it a bad port
    // to stop at. Neither may be an unknown option. Four at once: each run is mostly the loading
    // of the binary's libraries.
    std::vector<std::string> todo;
    for (const std::string& flag : flags)
        if (flag != "--help") todo.push_back(flag);
    for (std::size_t first = 0; first < todo.size(); first += 4) {
        std::vector<std::future<test::RunResult>> runs;
        for (std::size_t i = first; i < std::min(todo.size(), first + 4); ++i)
            runs.push_back(std::async(std::launch::async, [flag = todo[i]] {
                return test::run("serve --port 70000 " + flag);
            }));
        for (std::size_t i = 0; i < runs.size(); ++i) {
            const test::RunResult r = runs[i].get();
            EXPECT_EQ(r.err.find("unknown option"), std::string::npos)
                << todo[first + i] << ": " << r.err;
        }
    }
}

TEST(Cli, ServeRefusesBadConfigurationFromFlagsAndEnvironment) {
    struct Case {
        std::string command;
        const char* says;
    };
    for (const Case& c :
         {Case{"serve --cache-mb lots", "--cache-mb"}, Case{"serve --port 70000", "--port"},
          Case{"serve --backend vulkan", "vulkan"}, Case{"serve --formats png,gif", "gif"},
          Case{"serve --log-level loud", "--log-level"},
          Case{"serve --presets /no/such/presets.json", "--presets"},
          Case{"serve --no-such-flag", "--no-such-flag"}, Case{"serve extra", "positional"},
          Case{"TEXTOND_CACHE_MB=lots " + std::string(TEXTOND_BINARY) + " serve", "--cache-mb"},
          Case{"TEXTOND_PORT=-1 " + std::string(TEXTOND_BINARY) + " serve", "--port"}}) {
        // Cases that set the environment run the binary themselves through the shell.
        const bool env = c.command.rfind("TEXTOND_", 0) == 0;
        test::RunResult r;
        if (env) {
            const fs::path errfile = test::temp_path("serve-env-err");
            const int status =
                std::system((c.command + " >/dev/null 2>" + errfile.string()).c_str());
            r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
            std::FILE* e = std::fopen(errfile.c_str(), "r");
            std::array<char, 4096> buf{};
            while (std::size_t n = std::fread(buf.data(), 1, buf.size(), e))
                r.err.append(buf.data(), n);
            std::fclose(e);
        } else {
            r = test::run(c.command);
        }
        EXPECT_EQ(r.code, 2) << c.command << "\n" << r.err;
        EXPECT_NE(r.err.find(c.says), std::string::npos) << c.command << "\n" << r.err;
    }
}
