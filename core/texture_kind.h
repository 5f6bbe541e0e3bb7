#pragma once
// The micro/macro verdict's three answers: the shape verdict's (core/shape_verdict.h), and the
// first verdict's on the phase coherence index alone (core/phase_coherence.h), which still reads
// texton files written before the shape verdict.
namespace textond::core {

enum class TextureKind { micro, borderline, macro };

inline const char* to_string(TextureKind k) {
    return k == TextureKind::micro ? "micro" : k == TextureKind::macro ? "macro" : "borderline";
}

} // namespace textond::core
