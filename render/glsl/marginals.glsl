// Marginal restoration (core/README.md "Marginals"; core/marginals.h, after Heitz and Neyret, HPG 2018):
// the noise's value projected on the exemplar's principal colour directions, each component
// through its monotone table for this level, and back. Pointwise, so seamless. Compile after
// texton_eval.glsl with TEXTOND_MARGINALS defined (texton_noise.frag then applies it); the tables
// are rows of the kit's marginals.exr (row 3 level + i: component i at that level), sigma and
// basis in textond_kit.json.

uniform sampler2D u_marg_tables; // R32F, 256 x 3: row i is component i's table at this level
uniform mat3 u_marg_basis;       // columns: the exemplar's principal colour directions
uniform vec3 u_marg_mean;        // the exemplar's mean colour
uniform vec3 u_marg_sigma;       // this level's noise deviation along each direction
uniform int u_marg_channels;     // 1 (grey: one direction, 1) or 3

// Table i at y: 256 entries over y / sigma in [-6, 6], linear in between, clamped outside.
float marg_lookup(int i, float y) {
    float t = clamp((y / u_marg_sigma[i] + 6.0) / 12.0 * 255.0, 0.0, 255.0);
    int j = min(int(t), 254);
    float f = t - float(j);
    float a = texelFetch(u_marg_tables, ivec2(j, i), 0).r;
    float b = texelFetch(u_marg_tables, ivec2(j + 1, i), 0).r;
    return (1.0 - f) * a + f * b;
}

vec3 restore_marginals(vec3 v) {
    if (u_marg_channels == 1) return vec3(u_marg_mean.x + marg_lookup(0, v.x - u_marg_mean.x));
    vec3 y = transpose(u_marg_basis) * (v - u_marg_mean);
    vec3 o = vec3(marg_lookup(0, y.x), marg_lookup(1, y.y), marg_lookup(2, y.z));
    return u_marg_mean + u_marg_basis * o;
}
