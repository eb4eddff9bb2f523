// ---- btfgmm: LPCA, Mueller et al. 2003 (src/render/glsl/lpca.glsl) ----------------------
// Each texel's apparent BRDF is mean_a + sum_k w_k component_{a,k}, a its cluster; any
// position, light and view interpolated as measured_images.glsl says. Tables: texel p's
// cluster (a, -, -, -) at BTF_LPCA_CLUSTER + p and its weights from
// BTF_LPCA_WEIGHTS + p BTF_LPCA_GROUPS, four a texel; cluster a's mean BRDF (r, g, b, -) per
// pair q (light-major) at BTF_LPCA_MEAN + a pairs + q, its component k at
// BTF_LPCA_BASIS + (4 a BTF_LPCA_GROUPS + k) pairs + q.

vec3 btf(vec2 uv, vec3 light, vec3 view) {
  BtfBilinear at = btf_bilinear(uv);
  BtfWeights wl = btf_light_weights(light), wv = btf_view_weights(view);
  int pairs = BTF_LIGHTS * BTF_VIEWS;
  vec3 rgb = vec3(0.0);
  for (int c = 0; c < 4; ++c) {
    if (at.weight[c] == 0.0) continue;
    int p = at.pixel[c];
    int a = int(btf_texel(BTF_LPCA_CLUSTER + p).x);
    vec3 value = vec3(0.0);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        float pw = wl.weight[i] * wv.weight[j];
        if (pw == 0.0) continue;
        int q = wl.index[i] * BTF_VIEWS + wv.index[j];
        vec3 brdf = btf_texel(BTF_LPCA_MEAN + a * pairs + q).rgb;
        for (int g = 0; g < BTF_LPCA_GROUPS; ++g) {
          vec4 w = btf_texel(BTF_LPCA_WEIGHTS + p * BTF_LPCA_GROUPS + g);
          for (int k = 0; k < 4; ++k)
            brdf += w[k] *
                    btf_texel(BTF_LPCA_BASIS + (4 * (a * BTF_LPCA_GROUPS + g) + k) * pairs + q).rgb;
        }
        value += pw * brdf;
      }
    rgb += at.weight[c] * value;
  }
  return rgb;
}
