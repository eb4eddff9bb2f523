#version 450
// One layer's part of the neural BTF's parameter gradient for the fit (src/methods/
// neural_network_gpu.cpp), from what neural_gradient.comp kept of each sample: dE/dW_l[o][k] =
// the sum over the samples of delta_l[o] a_l[k], dE/db_l[o] = the sum of delta_l[o]. One
// invocation a parameter of the layer (its weights row-major, then its biases, as the flat
// vector holds them), the samples added in order, in runs of 64 whose float sums are added in
// order: the same sum at every run of the same device.
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Activations { float act[]; };
layout(std430, binding = 1) readonly buffer Deltas { float delta[]; };
layout(std430, binding = 2) writeonly buffer Gradient { float gradient[]; };

layout(push_constant) uniform Push {
  uint inputs, outputs, weights, act_at, delta_at, act_row, delta_row, count;
} pc;

void main() {
  const uint j = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 64 +
                 gl_LocalInvocationID.x;
  if (j >= pc.outputs * (pc.inputs + 1)) return;
  const bool bias = j >= pc.outputs * pc.inputs;
  const uint o = bias ? j - pc.outputs * pc.inputs : j / pc.inputs;
  const uint k = bias ? 0 : j % pc.inputs;
  float total = 0.0;
  for (uint first = 0; first < pc.count; first += 64) {
    float run = 0.0;
    const uint last = min(first + 64, pc.count);
    for (uint s = first; s < last; ++s) {
      const float dz = delta[s * pc.delta_row + pc.delta_at + o];
      run += bias ? dz : dz * act[s * pc.act_row + pc.act_at + k];
    }
    total += run;
  }
  gradient[pc.weights + j] = total;
}
