#include "render/gl/batch_plan.h"

#include "render/cancel.h"
#include "render/gl/noise_window.h"
#include "render/image_buffers.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <functional>
#include <map>

namespace textond::render::gl {

int words_per_pixel(Precision p) {
    return p == Precision::u8 ? 1 : p == Precision::u16 ? 2 : 3;
}

namespace {

// n words' three low bytes, packed: four pixels are two stores of 8 and 4 bytes, where a byte a
// store made a 4K frame's copy 2x slower (10 ms against 5 on one core here, memory-bound after).
void copy_rgb_bytes(const std::uint32_t* src, std::uint8_t* dst, int n) {
    constexpr std::uint32_t kRgb = 0xffffffu;
    int x = 0;
    for (; x + 4 <= n; x += 4, dst += 12) {
        const std::uint64_t lo = (src[x] & kRgb) | std::uint64_t{src[x + 1] & kRgb} << 24 |
                                 std::uint64_t{src[x + 2]} << 48;
        const std::uint32_t hi = ((src[x + 2] >> 16) & 0xffu) | (src[x + 3] & kRgb) << 8;
        std::memcpy(dst, &lo, 8);
        std::memcpy(dst + 8, &hi, 4);
    }
    for (; x < n; ++x, dst += 3) {
        const std::uint32_t v = src[x];
        dst[0] = static_cast<std::uint8_t>(v);
        dst[1] = static_cast<std::uint8_t>(v >> 8);
        dst[2] = static_cast<std::uint8_t>(v >> 16);
    }
}

// The pass's pixels into each piece's window: as the bytes themselves where the caller takes
// them (NoiseRequest::bytes), else as floats that encode to the same bytes (q / 255 scaled back by
// the encoder is q again: the error is far below its + 0.5).
void copy_out(const Piece& p, Precision precision, const std::uint32_t* words, int y_begin,
              int y_end) {
    core::Image& img = p.work->image.value();
    const int nc = img.channels;
    const int stride = words_per_pixel(precision);
    if (img.is_bytes()) { // the word's low bytes are the channels: copied as they are
        for (int y = y_begin; y < y_end; ++y) {
            const std::uint32_t* src = words + p.out_base + static_cast<std::size_t>(y) * p.w;
            std::uint8_t* dst = img.bytes.data() + (static_cast<std::size_t>(p.y0 + y) * img.width +
                                                    static_cast<std::size_t>(p.x0)) *
                                                       static_cast<std::size_t>(nc);
            if (nc == 3)
                copy_rgb_bytes(src, dst, p.w);
            else if (nc == 1)
                for (int x = 0; x < p.w; ++x) dst[x] = static_cast<std::uint8_t>(src[x]);
            else
                for (int x = 0; x < p.w; ++x)
                    for (int c = 0; c < nc; ++c)
                        *dst++ = static_cast<std::uint8_t>(src[x] >> (8 * c));
        }
        return;
    }
    for (int y = y_begin; y < y_end; ++y) {
        const std::uint32_t* src =
            words + (p.out_base + static_cast<std::size_t>(y) * p.w) * stride;
        for (int c = 0; c < nc; ++c) {
            float* dst = &img.at(c, p.x0, p.y0 + y);
            // A channel a loop, divided rather than looked up in a table of the same
            // divisions (the same floats), so that each loop vectorises.
            if (precision == Precision::u8)
                for (int x = 0; x < p.w; ++x)
                    dst[x] = static_cast<float>((src[x] >> (8 * c)) & 0xffu) / 255.0f;
            else if (precision == Precision::u16)
                for (int x = 0; x < p.w; ++x) {
                    const std::uint32_t w = src[2 * x + (c == 2 ? 1 : 0)];
                    dst[x] = static_cast<float>(c == 1 ? w >> 16 : w & 0xffffu) / 65535.0f;
                }
            else
                for (int x = 0; x < p.w; ++x) std::memcpy(&dst[x], &src[3 * x + c], 4);
        }
    }
}

// Every piece of a pass into its window, on all cores: on an H200 a 4K frame's conversion on
// one thread took 8x the GPU's time for it. Runs of rows are the unit, so a batch of small tiles
// and one large frame both spread.
void copy_out_all(const std::vector<Piece>& pieces, Precision precision,
                  const std::uint32_t* words) {
    constexpr int kRows = 32;
    std::vector<std::array<int, 3>> runs; // piece, first row, end row
    for (std::size_t i = 0; i < pieces.size(); ++i)
        if (pieces[i].work->image)
            for (int y = 0; y < pieces[i].h; y += kRows)
                runs.push_back({static_cast<int>(i), y, std::min(pieces[i].h, y + kRows)});
    const auto n = static_cast<std::ptrdiff_t>(runs.size());
#pragma omp parallel for schedule(dynamic, 4) if (n > 8)
    for (std::ptrdiff_t k = 0; k < n; ++k) {
        const auto& r = runs[static_cast<std::size_t>(k)];
        copy_out(pieces[static_cast<std::size_t>(r[0])], precision, words, r[1], r[2]);
    }
}

// Cuts the wanted windows into pieces; sorted by precision (one program a pass) and table (one
// dispatch a run), keeping each window's pieces in order.
std::vector<Piece> cut(const std::vector<GlBackend::Work*>& batch, std::size_t pass_words,
                       int piece_side) {
    std::vector<Piece> pieces;
    for (GlBackend::Work* work : batch) {
        const NoiseWindow& win = *work->window;
        if (stopped(win.cancel)) {
            work->image = abandoned(win.cancel, "the render");
            continue;
        }
        work->image = win.bytes ? take_bytes_image(win.width, win.height, win.channels)
                                : take_image(win.width, win.height, win.channels); // all written
        const int pw = std::min(win.width, piece_side);
        const int ph = std::max(
            1, std::min(win.height, static_cast<int>(pass_words / words_per_pixel(win.precision) /
                                                     static_cast<std::size_t>(pw))));
        const void* key = win.mix_tables.empty() ? static_cast<const void*>(win.table.get())
                                                 : static_cast<const void*>(work);
        for (int y0 = 0; y0 < win.height; y0 += ph)
            for (int x0 = 0; x0 < win.width; x0 += pw)
                pieces.push_back({work, x0, y0, std::min(pw, win.width - x0),
                                  std::min(ph, win.height - y0), 0, key});
    }
    std::stable_sort(pieces.begin(), pieces.end(), [](const Piece& a, const Piece& b) {
        const auto pa = a.work->window->precision, pb = b.work->window->precision;
        if (pa != pb) return pa < pb;
        return std::less<const void*>()(a.key, b.key);
    });
    return pieces;
}

std::vector<Pass> group(const std::vector<Piece>& pieces, std::size_t pass_words) {
    std::vector<Pass> passes;
    std::size_t records = 0;
    for (const Piece& p : pieces) {
        const Precision prec = p.work->window->precision;
        const std::size_t n = static_cast<std::size_t>(p.w) * p.h;
        const std::size_t cap = pass_words / static_cast<std::size_t>(words_per_pixel(prec));
        if (passes.empty() || passes.back().precision != prec || passes.back().pixels + n > cap)
            passes.push_back({prec, 0, {}, records});
        Pass& pass = passes.back();
        pass.pieces.push_back(p);
        pass.pieces.back().out_base = pass.pixels;
        pass.pixels += n;
        ++records;
    }
    return passes;
}

} // namespace

BatchPlan plan_batch(const std::vector<GlBackend::Work*>& batch, std::size_t pass_words,
                     int piece_side) {
    BatchPlan plan;
    plan.passes = group(cut(batch, pass_words, piece_side), pass_words);
    std::map<const GlBackend::Work*, std::array<std::uint32_t, 3>> bases; // thr, starts, points
    for (GlBackend::Work* work : batch) {
        const NoiseWindow& win = *work->window;
        bases[work] = {static_cast<std::uint32_t>(plan.thresholds.size()),
                       static_cast<std::uint32_t>(plan.starts.size()),
                       static_cast<std::uint32_t>(plan.points.size() / 4)};
        plan.thresholds.insert(plan.thresholds.end(), win.thresholds.begin(), win.thresholds.end());
        plan.starts.insert(plan.starts.end(), win.starts.begin(), win.starts.end());
        plan.points.insert(plan.points.end(), win.points.begin(), win.points.end());
    }
    for (auto* v : {&plan.thresholds, &plan.starts, &plan.points})
        if (v->size() < 4) v->resize(4, 0);
    for (const Pass& pass : plan.passes)
        for (const Piece& p : pass.pieces) {
            auto rec = p.work->window->record;
            const auto& b = bases[p.work];
            rec[field::thr_base] = b[0];
            rec[field::cell_base] = b[1];
            rec[field::point_base] = b[2];
            rec[field::offset_x] = static_cast<std::uint32_t>(p.x0);
            rec[field::offset_y] = static_cast<std::uint32_t>(p.y0);
            rec[field::size_x] = static_cast<std::uint32_t>(p.w);
            rec[field::size_y] = static_cast<std::uint32_t>(p.h);
            rec[field::out_base] = static_cast<std::uint32_t>(p.out_base);
            plan.records.insert(plan.records.end(), rec.begin(), rec.end());
        }
    return plan;
}

void copy_out_pass(const Pass& pass, const std::uint32_t* words) {
    copy_out_all(pass.pieces, pass.precision, words);
}

} // namespace textond::render::gl
