#version 450
#extension GL_EXT_control_flow_attributes : require
// The normal equations of the colour means' refit (src/model/refine.cpp,
// colour_normal_equations) on a compute device (src/model/refine_gpu.cpp): G = sum W W^T and
// b = sum W r^T over the samples of the slots refine_errors.comp wrote (the refit's training
// subsample), W_m = exp(t_m - mx) / sum the conditional weights of Eq. (9) and r the residual
// colour. A workgroup makes the 64 x 64 block (A, B) of G, A <= B (and, where A = B, the 64 x 3
// block A of b): 16 x 16 invocations of 4 x 4 entries each. The weights of 16 slots at a time
// are made in shared memory by the whole workgroup; each entry is summed in float over 256
// slots, then in double, in slot order.
layout(local_size_x = 16, local_size_y = 16) in;

layout(std430, binding = 0) readonly buffer PixelParts { float pixel_r[]; };  // row-major
layout(std430, binding = 1) readonly buffer LightParts { float light_r[]; };
layout(std430, binding = 2) readonly buffer ViewParts { float view_r[]; };
layout(std430, binding = 3) readonly buffer Residuals { vec4 residual[]; };
layout(std430, binding = 4) readonly buffer Slots { vec4 slot[]; };
// Block (A, B) at (A nb + B) 4096: entry (a, b) at a 64 + b; b's block A at A 192 + a 3 + c.
layout(std430, binding = 5) writeonly buffer GramBlocks { double gram[]; };
layout(std430, binding = 6) writeonly buffer RhsBlocks { double rhs[]; };

layout(push_constant) uniform Push {
  uint components, pixels, views, held, first_light, slots, blocks;
} pc;

const uint kSlotsAtOnce = 16;
const uint kFloatSlots = 256;  // slots summed in float before a sum in double
shared float wa[kSlotsAtOnce][64];
shared float wb[kSlotsAtOnce][64];
shared vec4 r_tile[kSlotsAtOnce];

// The weights of slot q (of `total`) for components a0 + j4 .. a0 + j4 + 3 and b0 + j4 ..,
// into shared row s; its residual colour by the first invocation of the row.
void load_weights(uint q, uint total, uint s, uint j4, uint a0, uint b0) {
  float mx = 0.0, inv = 0.0;
  uint p = 0, l = 0, v = 0;
  if (q < total) {
    const vec4 norm = slot[2 * q + 1];
    mx = norm.x;
    inv = norm.y;
    v = uint(norm.z);
    const uint lh = q / (pc.pixels * pc.slots);
    p = (q / pc.slots) % pc.pixels;
    l = pc.first_light + lh;
    if (j4 == 0)
      r_tile[s] = inv == 0.0 ? vec4(0.0) : residual[(lh * pc.pixels + p) * pc.views + v];
  } else if (j4 == 0) {
    r_tile[s] = vec4(0.0);
  }
  const uint m = pc.components;
  [[unroll]] for (uint i = 0; i < 4; ++i) {
    const uint a = a0 + j4 + i, b = b0 + j4 + i;
    float w = 0.0, u = 0.0;
    if (inv != 0.0 && a < m)
      w = exp(pixel_r[p * m + a] + light_r[l * m + a] + view_r[v * m + a] - mx) * inv;
    if (inv != 0.0 && b < m)
      u = exp(pixel_r[p * m + b] + light_r[l * m + b] + view_r[v * m + b] - mx) * inv;
    wa[s][j4 + i] = w;
    wb[s][j4 + i] = u;
  }
}

void main() {
  const uint block_a = gl_WorkGroupID.x, block_b = gl_WorkGroupID.y;
  if (block_a > block_b) return;  // the lower triangle is the upper's
  const uint tx = gl_LocalInvocationID.x, ty = gl_LocalInvocationID.y;
  const uint a0 = 64 * block_a, b0 = 64 * block_b;
  const bool diagonal = block_a == block_b;
  const uint total = pc.held * pc.pixels * pc.slots;
  float g[4][4];
  double gd[4][4];
  float b[4][3];
  double bd[4][3];
  [[unroll]] for (uint i = 0; i < 4; ++i) {
    [[unroll]] for (uint j = 0; j < 4; ++j) {
      g[i][j] = 0.0;
      gd[i][j] = 0.0;
    }
    [[unroll]] for (uint c = 0; c < 3; ++c) {
      b[i][c] = 0.0;
      bd[i][c] = 0.0;
    }
  }
  for (uint q0 = 0; q0 < total; q0 += kSlotsAtOnce) {
    barrier();  // the previous slots' reads are done
    load_weights(q0 + ty, total, ty, 4 * tx, a0, b0);
    barrier();
    // Unrolled: Mesa's lavapipe ends a loop nest after 65,535 iterations of its inner loops
    // in all, which a loop over the slots within the loop over their tiles would reach.
    [[unroll]] for (uint s = 0; s < kSlotsAtOnce; ++s) {
      [[unroll]] for (uint i = 0; i < 4; ++i) {
        const float w = wa[s][4 * tx + i];
        [[unroll]] for (uint j = 0; j < 4; ++j) g[i][j] += w * wb[s][4 * ty + j];
        if (diagonal && ty == 0) {
          const vec3 r = r_tile[s].xyz;
          [[unroll]] for (uint c = 0; c < 3; ++c) b[i][c] += w * r[c];
        }
      }
    }
    if ((q0 / kSlotsAtOnce + 1) % (kFloatSlots / kSlotsAtOnce) == 0 ||
        q0 + kSlotsAtOnce >= total) {
      [[unroll]] for (uint i = 0; i < 4; ++i) {
        [[unroll]] for (uint j = 0; j < 4; ++j) {
          gd[i][j] += double(g[i][j]);
          g[i][j] = 0.0;
        }
        [[unroll]] for (uint c = 0; c < 3; ++c) {
          bd[i][c] += double(b[i][c]);
          b[i][c] = 0.0;
        }
      }
    }
  }
  const uint at = (block_a * pc.blocks + block_b) * 4096;
  [[unroll]] for (uint i = 0; i < 4; ++i) {
    [[unroll]] for (uint j = 0; j < 4; ++j) gram[at + (4 * tx + i) * 64 + 4 * ty + j] = gd[i][j];
    if (diagonal && ty == 0)
      [[unroll]] for (uint c = 0; c < 3; ++c) rhs[block_a * 192 + (4 * tx + i) * 3 + c] = bd[i][c];
  }
}
