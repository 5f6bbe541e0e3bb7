// Test-only: evaluates the spec's building blocks for the vectors in render/noise_vectors.json.
// u_in holds one query per invocation (8 words); u_out receives up to 64 words per invocation.
layout(local_size_x = 1) in;
layout(std430, binding = 0) readonly buffer In { uint u_in[]; };
layout(std430, binding = 1) writeonly buffer Out { uint u_out[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint kind = u_in[i * 8u];
    uint base = i * 64u;
    if (kind == 0u) { // mix32(x)
        u_out[base] = mix32(u_in[i * 8u + 1u]);
    } else if (kind == 1u) { // cell_key(seed, cx, cy)
        u_out[base] = cell_key(uvec2(u_in[i * 8u + 1u], u_in[i * 8u + 2u]),
                               uvec2(u_in[i * 8u + 3u], u_in[i * 8u + 4u]),
                               uvec2(u_in[i * 8u + 5u], u_in[i * 8u + 6u]));
    } else if (kind == 2u) { // 8 draws of the stream from key
        uint state = u_in[i * 8u + 1u];
        for (uint k = 0u; k < 8u; ++k) u_out[base + k] = next_draw(state);
    } else if (kind == 3u) { // points of a cell: key, a -> n, then (qx, fx, qy, fy, sign) each
        uint state = u_in[i * 8u + 1u];
        uint a = u_in[i * 8u + 2u];
        int n = poisson_count(next_draw(state));
        u_out[base] = uint(n);
        for (int k = 0; k < n && k < 12; ++k) {
            int qx, qy;
            uint fx, fy;
            point_offset(next_draw(state), a, qx, fx);
            point_offset(next_draw(state), a, qy, fy);
            uint s = next_draw(state) >> 31u;
            u_out[base + 1u + uint(k) * 5u] = uint(qx);
            u_out[base + 2u + uint(k) * 5u] = fx;
            u_out[base + 3u + uint(k) * 5u] = uint(qy);
            u_out[base + 4u + uint(k) * 5u] = fy;
            u_out[base + 5u + uint(k) * 5u] = s;
        }
    } else if (kind == 4u) { // pixel_key(seed, level, px, py)
        u_out[base] = pixel_key(uvec2(u_in[i * 8u + 1u], u_in[i * 8u + 2u]), int(u_in[i * 8u + 3u]),
                                uvec2(u_in[i * 8u + 4u], u_in[i * 8u + 5u]),
                                uvec2(u_in[i * 8u + 6u], u_in[i * 8u + 7u]));
    }
}
