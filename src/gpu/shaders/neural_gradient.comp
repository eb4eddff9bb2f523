#version 450
// The neural BTF's squared error and back-propagation on the device for the fit (src/methods/
// neural_network_gpu.cpp), what squared_error_gradient() does on the CPU (methods/
// neural_network.hpp): one invocation a sample, its forward pass a_{l+1} = leaky(W_l a_l + b_l),
// y = W a + b at the output, E = |y - target|^2, then dE/dz of every layer's outputs from the
// top down (dE/dy = 2 (y - target); through a hidden layer, W^T delta times the leaky ReLU's
// slope, 1 where a > 0 and kLeakySlope elsewhere) and dE/dx of the latent inputs. Each sample
// keeps its layers' inputs (`act`, A values: the input x, then each hidden layer's output) and
// its layers' output gradients (`delta`, D values: each hidden layer's, then the output's), which
// neural_weight_gradient.comp sums into the parameters' gradient. With backward = 0 only the
// error (the validation).
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Parameters { float theta[]; };
layout(std430, binding = 1) readonly buffer Inputs { float x[]; };
layout(std430, binding = 2) readonly buffer Targets { float target[]; };
layout(std430, binding = 3) buffer Activations { float act[]; };
layout(std430, binding = 4) buffer Deltas { float delta[]; };
layout(std430, binding = 5) writeonly buffer LatentGradients { float dlatent[]; };
layout(std430, binding = 6) writeonly buffer Errors { float error[]; };

layout(push_constant) uniform Push {
  uint latents, width, depth, count, backward;
} pc;

const uint kDirections = 9;
const float kLeakySlope = 0.01;

// Where layer l's weights start in the flat parameter vector (methods/neural_network.hpp):
// W_0 (width x n_0) and b_0, then each (width x width) hidden layer and its biases.
uint weights_of(uint l, uint n0) {
  return l == 0 ? 0 : pc.width * (n0 + 1) + (l - 1) * pc.width * (pc.width + 1);
}

void main() {
  const uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 64 +
                 gl_LocalInvocationID.x;
  if (i >= pc.count) return;
  const uint n0 = pc.latents + kDirections, hidden_units = pc.depth * pc.width;
  const uint a = i * (n0 + hidden_units), d = i * (hidden_units + 3);
  for (uint k = 0; k < n0; ++k) act[a + k] = x[i * n0 + k];
  float e = 0.0;
  uint in_at = 0, inputs = n0;
  for (uint l = 0; l <= pc.depth; ++l) {
    const bool hidden = l < pc.depth;
    const uint outputs = hidden ? pc.width : 3, w = weights_of(l, n0);
    const uint biases = w + outputs * inputs, out_at = n0 + l * pc.width;
    for (uint o = 0; o < outputs; ++o) {
      float z = 0.0;
      for (uint k = 0; k < inputs; ++k) z += theta[w + o * inputs + k] * act[a + in_at + k];
      z += theta[biases + o];
      if (hidden) {
        act[a + out_at + o] = z < 0.0 ? kLeakySlope * z : z;
      } else {
        const float r = z - target[i * 3 + o];
        e += r * r;
        delta[d + hidden_units + o] = 2.0 * r;
      }
    }
    in_at = out_at;
    inputs = outputs;
  }
  error[i] = e;
  if (pc.backward == 0) return;
  for (uint l = pc.depth + 1; l-- > 0;) {
    const uint inputs_l = l == 0 ? n0 : pc.width, outputs_l = l == pc.depth ? 3 : pc.width;
    const uint w = weights_of(l, n0), out_at = l * pc.width;
    for (uint k = 0; k < inputs_l; ++k) {
      if (l == 0 && k >= pc.latents) break;
      float g = 0.0;
      for (uint o = 0; o < outputs_l; ++o) g += theta[w + o * inputs_l + k] * delta[d + out_at + o];
      if (l > 0) {
        const float below = act[a + n0 + (l - 1) * pc.width + k];
        delta[d + (l - 1) * pc.width + k] = below > 0.0 ? g : kLeakySlope * g;
      } else {
        dlatent[i * pc.latents + k] = g;
      }
    }
  }
}
