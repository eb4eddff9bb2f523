// ---- btfgmm: neural BTF, Rainer et al. 2019 (src/render/glsl/neural.glsl) ---------------
// A texel's latent (bilinear between the four texels around the position, the tile wrapping)
// and the light, view and half vectors (methods/neural_network.hpp, encode_directions) through
// the network: hidden layers leaky(W a + b), a linear output, times BTF_NEURAL_SCALE.
// Tables: texel p's latent from BTF_NEURAL_LATENTS + p BTF_NEURAL_LATENT_GROUPS, four values a
// texel; layer l's sizes in groups of four (inputs, outputs) at BTF_NEURAL_LAYER_TABLE + l;
// from BTF_NEURAL_ROWS, each layer's rows in turn, a row an output: its weights as its inputs
// lie (the first layer's: the latent's groups, then (light, 0), (view, 0), (half, 0)), then
// (bias, -, -, -).

vec3 btf(vec2 uv, vec3 light, vec3 view) {
  BtfBilinear at = btf_bilinear(uv);
  vec4 a[BTF_NEURAL_GROUPS];
  vec4 b[BTF_NEURAL_GROUPS];
  for (int g = 0; g < BTF_NEURAL_GROUPS; ++g) {
    a[g] = vec4(0.0);
    b[g] = vec4(0.0);
  }
  for (int g = 0; g < BTF_NEURAL_LATENT_GROUPS; ++g)
    for (int c = 0; c < 4; ++c)
      if (at.weight[c] != 0.0)
        a[g] += at.weight[c] *
                btf_texel(BTF_NEURAL_LATENTS + at.pixel[c] * BTF_NEURAL_LATENT_GROUPS + g);
  vec3 l = normalize(light), v = normalize(view), h = l + v;
  float h_length = length(h);
  a[BTF_NEURAL_LATENT_GROUPS] = vec4(l, 0.0);
  a[BTF_NEURAL_LATENT_GROUPS + 1] = vec4(v, 0.0);
  a[BTF_NEURAL_LATENT_GROUPS + 2] = vec4(h_length > 0.0 ? h / h_length : vec3(0.0), 0.0);
  int row = BTF_NEURAL_ROWS;
  for (int layer = 0; layer < BTF_NEURAL_LAYERS; ++layer) {
    vec4 sizes = btf_texel(BTF_NEURAL_LAYER_TABLE + layer);
    int inputs = int(sizes.x), outputs = int(sizes.y);
    for (int o = 0; o < outputs; ++o) {
      vec4 y = vec4(0.0);
      for (int k = 0; k < 4; ++k, row += inputs + 1) {
        float s = btf_texel(row + inputs).x;
        for (int g = 0; g < inputs; ++g) s += dot(a[g], btf_texel(row + g));
        y[k] = s;
      }
      b[o] = layer + 1 < BTF_NEURAL_LAYERS ? max(y, BTF_NEURAL_SLOPE * y) : y;
    }
    for (int g = 0; g < BTF_NEURAL_GROUPS; ++g) a[g] = b[g];
  }
  return BTF_NEURAL_SCALE * a[0].rgb;
}
