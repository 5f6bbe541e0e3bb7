#include "server/io/texton_file.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

using namespace textond;
namespace fs = std::filesystem;

namespace {
struct Analysed {
    core::Image exemplar;
    core::AnalysisParams params;
    io::TextonRecord record;
};

Analysed analyse(int threads, std::uint64_t seed = 1) {
    Analysed a;
    a.exemplar = test::crop(test::load_exemplar("etr_pebbles04.png"), 128, 96);
    a.params.size = 32;
    a.params.seed = seed;
    a.params.threads = threads;
    auto r = core::analyze_texton(a.exemplar, a.params);
    EXPECT_TRUE(r.ok());
    a.record = io::make_record(a.exemplar, a.params, r.value());
    return a;
}

} // namespace

TEST(TextonFile, RoundTripsBitExactly) {
    const Analysed a = analyse(1);
    const std::string path = test::temp_path("a.exr");
    ASSERT_TRUE(io::write_texton_file(path, a.record).ok());
    auto back = io::read_texton_file(path);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(back.value().texton.alpha.data, a.record.texton.alpha.data);
    EXPECT_EQ(back.value().meta.id, a.record.meta.id);
    EXPECT_EQ(back.value().meta.rme, a.record.meta.rme);
    EXPECT_EQ(back.value().texton.mean, a.record.texton.mean);
    EXPECT_EQ(back.value().texton.order, 1);
    ASSERT_TRUE(a.record.meta.phase_coherence && back.value().meta.phase_coherence);
    EXPECT_EQ(*back.value().meta.phase_coherence, *a.record.meta.phase_coherence);
    EXPECT_EQ(*back.value().meta.sharpness_index, *a.record.meta.sharpness_index);
    EXPECT_EQ(back.value().meta.kind(), "micro"); // pebbles
}

// The shape score round-trips; files written before it carry the phase coherence alone, whose
// kind they keep; files older still carry neither: read, answered without a kind.
TEST(TextonFile, ReadsMetadataWithoutTheShapeScoreOrThePhaseCoherence) {
    const Analysed a = analyse(1);
    nlohmann::json j = api::file_meta_json(a.record.meta);
    ASSERT_TRUE(a.record.meta.shape_score);
    EXPECT_EQ(j.at("kind"), "micro");
    EXPECT_EQ(j.at("shape_score"), *a.record.meta.shape_score);
    EXPECT_EQ(j.at("phase_coherence"), *a.record.meta.phase_coherence);
    EXPECT_EQ(j.get<api::TextonMeta>().shape_score, a.record.meta.shape_score);
    j.erase("shape_score");
    const auto older = j.get<api::TextonMeta>();
    EXPECT_FALSE(older.shape_score.has_value());
    EXPECT_EQ(older.kind(), core::to_string(core::texture_kind(*a.record.meta.phase_coherence)));
    for (const char* k : {"phase_coherence", "sharpness_index", "kind"}) j.erase(k);
    const auto old = j.get<api::TextonMeta>();
    EXPECT_FALSE(old.phase_coherence.has_value());
    EXPECT_EQ(old.kind(), "");
    EXPECT_FALSE(nlohmann::json(old).contains("kind"));
    EXPECT_EQ(old.id, a.record.meta.id);
}

// Three verdicts from a stored phase coherence index (files written before the shape score), at
// its thresholds; a shape score, when stored, decides instead.
TEST(TextonFile, KindIsMicroBorderlineOrMacroFromTheStoredIndex) {
    api::TextonMeta m;
    const std::pair<double, const char*> cases[] = {{0.0, "micro"},         {0.046, "micro"},
                                                    {0.0461, "borderline"}, {0.077, "borderline"},
                                                    {0.0771, "macro"},      {0.3, "macro"}};
    for (const auto& [index, kind] : cases) {
        m.phase_coherence = index;
        EXPECT_EQ(m.kind(), kind) << index;
    }
    m.shape_score = -1.0;
    EXPECT_EQ(m.kind(), "micro");
}

TEST(TextonFile, IdIsContentAddressedAndThreadIndependent) {
    const Analysed a = analyse(1), b = analyse(2), c = analyse(1, 2);
    EXPECT_EQ(a.record.meta.id.size(), 64u);
    EXPECT_EQ(a.record.meta.id, b.record.meta.id);
    EXPECT_EQ(a.record.meta.coefficients_sha256, b.record.meta.coefficients_sha256);
    EXPECT_NE(a.record.meta.id, c.record.meta.id); // seed is a parameter
    core::Image changed = a.exemplar;
    changed.data[5] += 1.0f / 255.0f;
    EXPECT_NE(io::texton_id(changed, a.params), a.record.meta.id);
}

// Content-addressed means one id, one body: replicas that analyse the same exemplar on their
// own must serve the same texton.exr (and ETag). Timings and the store time stay out of it.
// A large exemplar's texton comes from its working window: its id says so, a small one's is
// what it always was.
TEST(TextonFile, AWindowedAnalysisHasAnIdOfItsOwn) {
    core::AnalysisParams p, whole;
    whole.working_side = 0;
    const core::Image large(1100, 64, 1, 0.5f), small(1024, 64, 1, 0.5f);
    EXPECT_NE(io::texton_id(large, p), io::texton_id(large, whole));
    EXPECT_EQ(io::texton_id(small, p), io::texton_id(small, whole));
}

TEST(TextonFile, TwoAnalysesOfOneExemplarAreTheSameBytes) {
    const Analysed a = analyse(1), b = analyse(2);
    ASSERT_TRUE(a.record.meta.timings);
    auto fa = io::texton_file_bytes(a.record), fb = io::texton_file_bytes(b.record);
    ASSERT_TRUE(fa.ok() && fb.ok());
    EXPECT_EQ(fa.value(), fb.value());

    // Provenance that differs cannot change the bytes, and none of it is in them.
    io::TextonRecord late = a.record;
    late.meta.created = "2031-01-01T00:00:00Z";
    late.meta.timings->total_ms += 1234.5;
    auto fl = io::texton_file_bytes(late);
    ASSERT_TRUE(fl.ok());
    EXPECT_EQ(fl.value(), fa.value());
    EXPECT_EQ(fa.value().find("timings_ms"), std::string::npos);
    EXPECT_EQ(fa.value().find("created"), std::string::npos);

    // Read back, a file has no provenance: it is not the file's to tell.
    const std::string path = test::temp_path("provenance.exr");
    ASSERT_TRUE(io::write_texton_file(path, late).ok());
    auto back = io::read_texton_file(path);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_FALSE(back.value().meta.timings);
    EXPECT_TRUE(back.value().meta.created.empty());
}

TEST(TextonFile, DamagedFileIsRefused) {
    Analysed a = analyse(1);
    a.record.meta.coefficients_sha256 = std::string(64, '0');
    const std::string path = test::temp_path("damaged.exr");
    ASSERT_TRUE(io::write_texton_file(path, a.record).ok());
    auto r = io::read_texton_file(path);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("checksum"), std::string::npos);
    // An ordinary image is not a texton file.
    EXPECT_FALSE(io::read_texton_file(test::exemplar_path("etr_sand01.png")).ok());
}

TEST(TextonFile, ExportsTheAuthorsV1Format) {
    const Analysed a = analyse(1);
    const std::string text = io::texton_v1_text(a.record, "pebbles.png");
    std::istringstream in(text);
    std::string line;
    std::vector<std::string> lines;
    while (std::getline(in, line)) lines.push_back(line);
    const int framed = 32 + 2;
    ASSERT_EQ(lines.size(), 5u + framed * framed + 1u);
    EXPECT_EQ(lines[0], "TEXTON");
    EXPECT_EQ(lines[1], "1");
    EXPECT_EQ(lines[2], "1");
    EXPECT_EQ(lines[4], "34 34");
    EXPECT_EQ(lines[5], "0.000000e+00 0.000000e+00 0.000000e+00"); // the zero frame
    // First inner texel listed is the bottom-left one: alpha(x = 0, y = r - 1).
    float r = 0, g = 0, b = 0;
    std::istringstream(lines[5 + framed + 1]) >> r >> g >> b;
    EXPECT_FLOAT_EQ(r, a.record.texton.alpha.at(0, 0, 31));
    EXPECT_FLOAT_EQ(b, a.record.texton.alpha.at(2, 0, 31));
    EXPECT_EQ(lines.back(), "Original image: pebbles.png (128 x 96)");
}
