// The fragment entry point of a material set (engine kit): every map and the normal map of one
// pixel in one pass, to three colour attachments. Compile noise_lib.glsl + texton_eval.glsl +
// material_eval.glsl + this file; set texton_eval's uniforms as for one texton (u_mode 0).

uniform float u_strength; // normals: the texels a height step of 1 spans (the server's strength=)

layout(location = 0) out vec4 o_maps0;  // channels 0..3 (textond_kit.json "maps" says which)
layout(location = 1) out vec4 o_maps1;  // channels 4..7
layout(location = 2) out vec4 o_normal; // n / 2 + 1/2 (tangent space, +Y up), or 0: no height

void main() {
    ivec2 pix = ivec2(gl_FragCoord.xy) + u_offset;
    SetPixel s = set_pixel(pix);
    o_maps0 = s.c0;
    o_maps1 = s.c1;
    // render/normal_map.h: n = normalize(-s dh/dx, +s dh/drow, 1)
    vec3 n = normalize(vec3(-u_strength * s.grad.x, u_strength * s.grad.y, 1.0));
    o_normal = u_height >= 0 ? vec4(0.5 * n + 0.5, 1.0) : vec4(0.0);
}
