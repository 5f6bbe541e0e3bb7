#pragma once
// A batch of windows planned for the GL evaluator, with no GL: cut into pieces that fit one
// pass's output buffer, grouped into passes (one program a pass, one dispatch a run of pieces of
// one level table), and packed into the buffers a batch uploads once (thresholds, listed points,
// a record a piece). After a pass, copy_out_pass converts its readback into the windows.
#include "render/gl/gl_backend.h"
#include "render/noise_request.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace textond::render::gl {

int words_per_pixel(Precision p); // one at 8 bits, two at 16, three as floats

// A piece of one window that fits a pass: where it is in its window and in the pass's output.
struct Piece {
    GlBackend::Work* work;
    int x0, y0, w, h;
    std::size_t out_base = 0; // pixels from the start of the pass's output
    const void* key;          // the level table its dispatch binds (a mix: its own)
};

struct Pass {
    Precision precision;
    std::size_t pixels = 0;
    std::vector<Piece> pieces;    // runs of one key are one dispatch
    std::size_t first_record = 0; // its first piece's record in BatchPlan::records
};

struct BatchPlan {
    std::vector<Pass> passes;
    // Every window's thresholds and listed points (each at least 4 words: a bound buffer may not
    // be empty), and every piece's record pointing into them, in pass order.
    std::vector<std::uint32_t> thresholds, starts, points, records;
};

// The windows still wanted (a stopped one is answered as abandoned and left out) get their
// image; pieces at most `piece_side` wide and `pass_words` output words, sorted by precision and
// table, each window's pieces in order.
BatchPlan plan_batch(const std::vector<GlBackend::Work*>& batch, std::size_t pass_words,
                     int piece_side);

// A pass's readback (`words`) into each piece's window, as the bytes the GPU rounded to (a window
// of core::Image::bytes) or as floats that encode to them, on all cores.
void copy_out_pass(const Pass& pass, const std::uint32_t* words);

} // namespace textond::render::gl
