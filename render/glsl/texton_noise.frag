// The fragment entry point of texton noise (NOISE_SPEC.md section 7): one pixel a fragment, for
// engines that draw the noise as a full-screen pass. Compile noise_lib.glsl + texton_eval.glsl +
// this file; the server itself runs the same evaluation as compute (texton_noise.comp).

layout(location = 0) out vec4 o_color;

void main() {
    ivec2 pix = ivec2(gl_FragCoord.xy) + u_offset;
    vec3 v = u_mode == 0 ? exact_pixel(pix) : limit_pixel(pix);
#ifdef TEXTOND_MARGINALS
    v = restore_marginals(v); // marginals.glsl: the exemplar's colour distribution
#endif
    o_color = vec4(v, 1.0);
}
