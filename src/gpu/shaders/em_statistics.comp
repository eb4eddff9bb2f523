#version 450
#extension GL_EXT_control_flow_attributes : require
// The E pass, second half (src/model/em_gpu.cpp): the responsibilities q = exp(t - mx) / sum
// of Eq. (4) folded into the sufficient statistics of the M-step, Eq. (5)-(7), of one
// component column over one chunk of pixels of one light. Per (pixel, light) block in float
// (as the CPU's blocks; a block of more than kViewTile views in pieces of kViewTile), then in
// double: sum q; sum q dx, q dx^2, q dy, q dy^2 (the pixel's minimum-image distances); the
// view angles' sum q d, q d^2; the colours' sum q d, q d^2 (d = value - the component's mean).
// The workgroup is 64 columns x 4 lanes, each lane a pixel at a time: the views' terms V of
// its columns, and the four pixels' residuals and normalisers, are read into shared memory
// by the whole workgroup at once (so that no column waits on its own loads), and the lanes
// are added in order at the end: 15 rows of stride doubles per (light, chunk).
layout(local_size_x = 64, local_size_y = 4) in;

#include "em_common.glsl"

layout(std430, binding = 5) readonly buffer Normaliser { vec2 normaliser[]; };
layout(std430, binding = 6) readonly buffer Offsets { double offsets[]; };  // dx W x st, dy H x st
layout(std430, binding = 7) readonly buffer ViewAngles { vec2 view_ab[]; };  // (alpha, beta)
layout(std430, binding = 8) readonly buffer ViewMeans { float view_mu[]; };  // 2 x stride
layout(std430, binding = 9) writeonly buffer ChunkSums { double chunk_sums[]; };

layout(push_constant) uniform Push {
  uint stride, components, pixels, views, held, first_light, width, chunks;
} pc;

const uint kRows = 15;
// Views a tile: its V (64 columns), residuals and normalisers (4 pixels) and the lanes' sums
// take 31,616 bytes of shared memory, within every device's 32 KiB.
const uint kViewTile = 84;
shared float v_tile[kViewTile][64];
shared vec4 residual_tile[4][kViewTile];
shared vec2 normaliser_tile[4][kViewTile];
shared double lanes[4][64];

// The residuals and normalisers of the views [v0, v0 + nv) of the pixels first .. first + 3
// (those before `last`) of held light lh, by every invocation of the workgroup.
void load_pixels(uint lh, uint first, uint last, uint v0, uint nv) {
  for (uint t = gl_LocalInvocationIndex; t < 4 * nv; t += 256) {
    const uint lane = t / nv, i = t % nv, p = first + lane;
    if (p >= last) continue;
    const uint n = (lh * pc.pixels + p) * pc.views + v0 + i;
    residual_tile[lane][i] = residual[n];
    normaliser_tile[lane][i] = normaliser[n];
  }
}

void main() {
  const uint k = gl_GlobalInvocationID.x, lane = gl_LocalInvocationID.y;
  const uint kl = gl_LocalInvocationID.x;
  const uint lh = gl_WorkGroupID.y / pc.chunks, c = gl_WorkGroupID.y % pc.chunks;
  const bool live = k < pc.components;
  double sums[kRows];
  [[unroll]] for (uint j = 0; j < kRows; ++j) sums[j] = 0.0;
  const uint first = c * pc.pixels / pc.chunks, last = (c + 1) * pc.pixels / pc.chunks;
  const uint lrow = (pc.first_light + lh) * pc.stride;
  const vec3 mu = live ? colour_mean(k) : vec3(0.0), h = live ? colour_h(k) : vec3(0.0);
  const vec2 mu_view = live ? vec2(view_mu[k], view_mu[pc.stride + k]) : vec2(0.0);
  for (uint v0 = 0; v0 < pc.views; v0 += kViewTile) {
    const uint nv = min(kViewTile, pc.views - v0);
    barrier();  // the previous tile's reads are done
    for (uint i = lane; i < nv; i += 4) v_tile[i][kl] = live ? v_table[(v0 + i) * pc.stride + k] : 0.0;
    for (uint p0 = first; p0 < last; p0 += 4) {
      barrier();  // the previous pixels' reads are done
      load_pixels(lh, p0, last, v0, nv);
      barrier();
      const uint p = p0 + lane;
      if (!live || p >= last) continue;
      const float sl = s_table[p * pc.stride + k] + l_table[lrow + k];
      float q0 = 0.0;
      vec2 a1 = vec2(0.0), a2 = vec2(0.0);
      vec3 c1 = vec3(0.0), c2 = vec3(0.0);
      for (uint i = 0; i < nv; ++i) {
        const vec3 d = residual_tile[lane][i].xyz - mu;
        const vec2 norm = normaliser_tile[lane][i];
        const float q = exp(log_density(sl, v_tile[i][kl], d, h) - norm.x) * norm.y;
        const vec2 e = view_ab[v0 + i] - mu_view;
        q0 += q;
        c1 += q * d;
        c2 += q * d * d;
        a1 += q * e;
        a2 += q * e * e;
      }
      const double dx = offsets[(p % pc.width) * pc.stride + k];
      const double dy = offsets[(pc.width + p / pc.width) * pc.stride + k];
      const double q = double(q0);
      sums[0] += q;
      sums[1] += q * dx;
      sums[2] += q * dx * dx;
      sums[3] += q * dy;
      sums[4] += q * dy * dy;
      sums[5] += double(a1.x);
      sums[6] += double(a2.x);
      sums[7] += double(a1.y);
      sums[8] += double(a2.y);
      [[unroll]] for (uint ch = 0; ch < 3; ++ch) {
        sums[9 + ch] += double(c1[ch]);
        sums[12 + ch] += double(c2[ch]);
      }
    }
  }
  const uint at = gl_WorkGroupID.y * kRows * pc.stride;
  [[unroll]] for (uint j = 0; j < kRows; ++j) {
    lanes[lane][kl] = sums[j];
    barrier();
    if (lane == 0 && live)
      chunk_sums[at + j * pc.stride + k] =
          ((lanes[0][kl] + lanes[1][kl]) + lanes[2][kl]) + lanes[3][kl];
    barrier();
  }
}
