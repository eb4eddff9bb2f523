#version 450
#extension GL_EXT_control_flow_attributes : require
// The fit for the prediction on a compute device, second half (src/model/refine_gpu.cpp): the
// gradient of the squared error (refine_gradient.cpp, GradientPass) of one component column
// over one chunk of pixels of one light, from the slots refine_errors.comp wrote. A sample's
// g_m = dE/dt_m = -2 W_m (e . mu_m,6+c - e . yhat) summed per (pixel, light) block in float,
// then in double, into 12 rows: sum g; sum g times the pixel's d / sigma^2 and
// (d^2 / sigma^2 - 1) / 2 of x and y (the minimum image); sum g d / sigma^2 and
// g (d^2 / sigma^2 - 1) / 2 of the view's two angles; sum -2 W_m e_c. The light's angles are
// the host's, from the light's sum g. The workgroup is 64 columns x 4 lanes, each lane a pixel
// at a time, the four pixels' slots read into shared memory by the whole workgroup; the lanes
// are added in order at the end.
layout(local_size_x = 64, local_size_y = 4) in;

// The parts of t_m, row-major (a row's components side by side).
layout(std430, binding = 0) readonly buffer PixelParts { float pixel_r[]; };
layout(std430, binding = 1) readonly buffer LightParts { float light_r[]; };
layout(std430, binding = 2) readonly buffer ViewParts { float view_r[]; };
// Per component 5 vec4 (refine_tables.comp): (mu_6..8, 0), (mu_0, mu_1, 1 / sigma^2_0,
// 1 / sigma^2_1), the same of the view's angles, ...
layout(std430, binding = 3) readonly buffer Components { vec4 comp[]; };
layout(std430, binding = 4) readonly buffer ViewAngles { vec2 view_ab[]; };
layout(std430, binding = 5) readonly buffer Slots { vec4 slot[]; };
// Per (row, held light, chunk) M sums: em_light_sums.comp then adds a light's chunks, and the
// lights of a row.
layout(std430, binding = 6) writeonly buffer ChunkSums { double chunk_sums[]; };

layout(push_constant) uniform Push {
  uint components, pixels, views, held, first_light, width, chunks, slots;
  float period_x, period_y;
} pc;

const uint kRows = 12;
const uint kSlotTile = 64;
shared vec4 slot_e[4][kSlotTile];
shared vec4 slot_n[4][kSlotTile];
shared double lanes[4][64];

// The slots [i0, i0 + n) of the pixels first .. first + 3 (those before `last`) of held light
// lh, by every invocation of the workgroup.
void load_slots(uint lh, uint first, uint last, uint i0, uint n) {
  for (uint t = gl_LocalInvocationIndex; t < 4 * n; t += 256) {
    const uint lane = t / n, i = t % n, p = first + lane;
    if (p >= last) continue;
    const uint at = 2 * ((lh * pc.pixels + p) * pc.slots + i0 + i);
    slot_e[lane][i] = slot[at];
    slot_n[lane][i] = slot[at + 1];
  }
}

// d / sigma^2 and (d^2 / sigma^2 - 1) / 2 of coordinate x, d its minimum image to the mean.
vec2 position_rows(float x, float mean, float inv_var, float period) {
  float d = x - mean;
  if (period > 0.0) d -= period * floor(d / period + 0.5);
  const float r = d * inv_var;
  return vec2(r, 0.5 * (d * r - 1.0));
}

void main() {
  const uint k = gl_GlobalInvocationID.x, lane = gl_LocalInvocationID.y;
  const uint kl = gl_LocalInvocationID.x;
  const uint lh = gl_WorkGroupID.y / pc.chunks, c = gl_WorkGroupID.y % pc.chunks;
  const bool live = k < pc.components;
  double sums[kRows];
  [[unroll]] for (uint j = 0; j < kRows; ++j) sums[j] = 0.0;
  const uint first = c * pc.pixels / pc.chunks, last = (c + 1) * pc.pixels / pc.chunks;
  const uint l = pc.first_light + lh;
  const float tl = live ? light_r[l * pc.components + k] : 0.0;
  const vec3 mu = live ? comp[5 * k].xyz : vec3(0.0);
  const vec4 sp = live ? comp[5 * k + 1] : vec4(0.0);
  const vec4 vi = live ? comp[5 * k + 2] : vec4(0.0);
  for (uint p0 = first; p0 < last; p0 += 4) {
    const uint p = p0 + lane;
    const bool mine = live && p < last;
    const float tp = mine ? pixel_r[p * pc.components + k] + tl : 0.0;
    float g_sum = 0.0;
    vec2 view_mean = vec2(0.0), view_s = vec2(0.0);
    vec3 colour = vec3(0.0);
    for (uint i0 = 0; i0 < pc.slots; i0 += kSlotTile) {
      const uint n = min(kSlotTile, pc.slots - i0);
      barrier();  // the previous slots' reads are done
      load_slots(lh, p0, last, i0, n);
      barrier();
      if (!mine) continue;
      for (uint i = 0; i < n; ++i) {
        const vec4 norm = slot_n[lane][i];
        if (norm.y == 0.0) continue;
        const uint v = uint(norm.z);
        const float w = exp(tp + view_r[v * pc.components + k] - norm.x) * norm.y;
        const vec4 e = slot_e[lane][i];
        const float g = -2.0 * w * (dot(e.xyz, mu) - e.w);
        const vec2 d = view_ab[v] - vi.xy;
        const vec2 r = d * vi.zw;
        g_sum += g;
        view_mean += g * r;
        view_s += g * (0.5 * (d * r - 1.0));
        colour += (-2.0 * w) * e.xyz;
      }
    }
    if (!mine) continue;
    const vec2 rx = position_rows(float(p % pc.width), sp.x, sp.z, pc.period_x);
    const vec2 ry = position_rows(float(p / pc.width), sp.y, sp.w, pc.period_y);
    const double g = double(g_sum);
    sums[0] += g;
    sums[1] += g * double(rx.x);
    sums[2] += g * double(ry.x);
    sums[3] += g * double(rx.y);
    sums[4] += g * double(ry.y);
    sums[5] += double(view_mean.x);
    sums[6] += double(view_mean.y);
    sums[7] += double(view_s.x);
    sums[8] += double(view_s.y);
    [[unroll]] for (uint ch = 0; ch < 3; ++ch) sums[9 + ch] += double(colour[ch]);
  }
  [[unroll]] for (uint j = 0; j < kRows; ++j) {
    lanes[lane][kl] = sums[j];
    barrier();
    if (lane == 0 && live)
      chunk_sums[((j * pc.held + lh) * pc.chunks + c) * pc.components + k] =
          ((lanes[0][kl] + lanes[1][kl]) + lanes[2][kl]) + lanes[3][kl];
    barrier();
  }
}
