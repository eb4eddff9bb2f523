#version 450
// The neural BTF's network (methods/neural_network.hpp; Rainer et al. 2019) on the device for
// decode and eval (src/methods/neural_btf_gpu.cpp), the forward pass neural_network.cpp makes
// on the CPU: a_{l+1} = leaky(W_l a_l + b_l) for the hidden layers, y = W a + b at the output,
// W_l row-major (outputs x inputs) then b_l in the flat parameter vector, times the stored
// scale. One invocation a query, its input the texel's latent then the 9 direction values. On
// the grid (decode), query i is texel i % pixels of pair i / pixels, the latents a texel's row
// and the directions a pair's; otherwise (eval) query i has row i of each.
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Parameters { float theta[]; };
layout(std430, binding = 1) readonly buffer Latents { float latent[]; };
layout(std430, binding = 2) readonly buffer Directions { float direction[]; };
layout(std430, binding = 3) writeonly buffer Colours { float colour[]; };

layout(push_constant) uniform Push {
  uint latents, width, depth, pixels, grid, first, count;
  float scale;
} pc;

// kMaxWidth units, and the first layer's inputs (kMaxLatent + 9) at most.
const uint kUnits = 512;
const uint kDirections = 9;
const float kLeakySlope = 0.01;

float units[2][kUnits];

void main() {
  const uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 64 +
                 gl_LocalInvocationID.x;
  if (i >= pc.count) return;
  const uint q = pc.first + i;
  const uint p = pc.grid != 0 ? q % pc.pixels : q, pair = pc.grid != 0 ? q / pc.pixels : q;
  for (uint j = 0; j < pc.latents; ++j) units[0][j] = latent[p * pc.latents + j];
  for (uint j = 0; j < kDirections; ++j)
    units[0][pc.latents + j] = direction[pair * kDirections + j];
  uint at = 0, from = 0, inputs = pc.latents + kDirections;
  for (uint l = 0; l <= pc.depth; ++l) {
    const bool hidden = l < pc.depth;
    const uint outputs = hidden ? pc.width : 3;
    const uint biases = at + outputs * inputs;
    for (uint o = 0; o < outputs; ++o) {
      float z = 0.0;
      for (uint k = 0; k < inputs; ++k) z += theta[at + o * inputs + k] * units[from][k];
      z += theta[biases + o];
      units[1 - from][o] = hidden && z < 0.0 ? kLeakySlope * z : z;
    }
    at = biases + outputs;
    from = 1 - from;
    inputs = outputs;
  }
  for (uint c = 0; c < 3; ++c) colour[i * 3 + c] = units[from][c] * pc.scale;
}
